#include "stereo_safety_map/dataset/scene.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace stereo_safety_map {
namespace dataset {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool finite3(const Eigen::Vector3d& v) {
  return v.allFinite();
}
bool finite3f(const Eigen::Vector3f& v) {
  return v.allFinite();
}

// Orthonormal basis with `a` as its third column.
Eigen::Matrix3d basisAround(const Eigen::Vector3d& a) {
  const Eigen::Vector3d helper =
      std::abs(a.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d x = helper.cross(a).normalized();
  const Eigen::Vector3d y = a.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = a;
  return R;
}

}  // namespace

const char* toString(TextureKind k) {
  switch (k) {
    case TextureKind::kPlain:
      return "plain";
    case TextureKind::kNoise:
      return "noise";
    case TextureKind::kSpeckle:
      return "speckle";
    case TextureKind::kTiles:
      return "tiles";
    case TextureKind::kBricks:
      return "bricks";
    case TextureKind::kStripes:
      return "stripes";
    case TextureKind::kChecker:
      return "checker";
  }
  return "unknown";
}

bool parseTextureKind(const std::string& s, TextureKind* k) {
  static const TextureKind kAll[] = {
      TextureKind::kPlain,  TextureKind::kNoise,   TextureKind::kSpeckle, TextureKind::kTiles,
      TextureKind::kBricks, TextureKind::kStripes, TextureKind::kChecker};
  for (TextureKind c : kAll) {
    if (s == toString(c)) {
      *k = c;
      return true;
    }
  }
  return false;
}

std::string Material::validate() const {
  if (!(std::isfinite(scale) && scale > 0.0)) return "material.scale must be > 0 [m]";
  if (!(contrast >= 0.0 && contrast <= 1.0)) return "material.contrast must be in [0, 1]";
  if (!finite3f(colour) || colour.minCoeff() < 0.0f || colour.maxCoeff() > 1.0f)
    return "material.colour components must be in [0, 1]";
  if (!(line_width >= 0.0 && line_width < 0.5)) return "material.line_width must be in [0, 0.5)";
  if (!(detail >= 0.0 && detail <= 1.0)) return "material.detail must be in [0, 1]";
  if (!(grain <= 1.0) || (grain < 0.0 && grain != -1.0))
    return "material.grain must be in [0, 1] (or absent for the default)";
  if (!(std::isfinite(grain_size) && grain_size > 0.0))
    return "material.grain_size must be > 0 [m]";
  if (!std::isfinite(angle_deg)) return "material.angle_deg must be finite";
  return "";
}

std::string Lighting::validate() const {
  if (!finite3(direction) || direction.norm() < 1e-9)
    return "lighting.direction must be a finite non-zero vector";
  if (!(std::isfinite(ambient) && ambient >= 0.0)) return "lighting.ambient must be >= 0";
  if (!(std::isfinite(diffuse) && diffuse >= 0.0)) return "lighting.diffuse must be >= 0";
  if (ambient + diffuse <= 0.0) return "lighting.ambient + lighting.diffuse must be > 0";
  return "";
}

bool Primitive::interval(const Ray& ray, double* t_in, double* t_out, int* entry_face) const {
  double tin = -kInf, tout = kInf;
  int face = -1;
  if (shape == Shape::kConvex) {
    for (std::size_t i = 0; i < planes.size(); ++i) {
      const HalfSpace& h = planes[i];
      const double denom = h.n.dot(ray.dir);
      const double dist = h.d - h.n.dot(ray.origin);  // >= 0 when the origin is inside
      if (std::abs(denom) < 1e-300) {
        if (dist < 0.0) return false;
        continue;
      }
      const double t = dist / denom;
      if (denom < 0.0) {
        if (t > tin) {
          tin = t;
          face = static_cast<int>(i);
        }
      } else if (t < tout) {
        tout = t;
      }
      if (tin > tout) return false;
    }
    if (planes.empty()) return false;
  } else {
    const Eigen::Vector3d o = ray.origin - p0;
    const double da = ray.dir.dot(axis);
    const double oa = o.dot(axis);
    double s_in = -kInf, s_out = kInf;
    if (std::abs(da) < 1e-300) {
      if (oa < 0.0 || oa > length) return false;
    } else {
      const double t1 = -oa / da, t2 = (length - oa) / da;
      s_in = std::min(t1, t2);
      s_out = std::max(t1, t2);
    }
    const Eigen::Vector3d dp = ray.dir - da * axis;
    const Eigen::Vector3d op = o - oa * axis;
    const double A = dp.squaredNorm();
    const double C = op.squaredNorm() - radius * radius;
    double q_in = -kInf, q_out = kInf;
    if (A < 1e-300) {
      if (C > 0.0) return false;
    } else {
      const double B = 2.0 * op.dot(dp);
      const double disc = B * B - 4.0 * A * C;
      if (disc < 0.0) return false;
      const double sq = std::sqrt(disc);
      q_in = (-B - sq) / (2.0 * A);
      q_out = (-B + sq) / (2.0 * A);
    }
    if (s_in > q_in) {
      tin = s_in;
      face = -2;
    } else {
      tin = q_in;
      face = -1;
    }
    tout = std::min(s_out, q_out);
    if (tin > tout) return false;
  }
  *t_in = tin;
  *t_out = tout;
  *entry_face = face;
  return true;
}

Eigen::Vector3d Primitive::normalAt(int face, const Eigen::Vector3d& p) const {
  if (shape == Shape::kConvex) {
    if (face >= 0 && face < static_cast<int>(planes.size())) return planes[face].n;
    return Eigen::Vector3d::UnitZ();
  }
  const Eigen::Vector3d o = p - p0;
  const double s = o.dot(axis);
  if (face == -2) return s < 0.5 * length ? Eigen::Vector3d(-axis) : axis;
  const Eigen::Vector3d radial = o - s * axis;
  const double n = radial.norm();
  return n > 1e-12 ? Eigen::Vector3d(radial / n) : basisAround(axis).col(0);
}

bool Primitive::topHeightAt(double x, double y, double* z, double eps) const {
  if (shape != Shape::kConvex || top_face < 0) return false;
  const HalfSpace& top = planes[top_face];
  if (top.n.z() <= 1e-6) return false;
  const double zt = (top.d - top.n.x() * x - top.n.y() * y) / top.n.z();
  const Eigen::Vector3d p(x, y, zt);
  for (std::size_t i = 0; i < planes.size(); ++i) {
    if (static_cast<int>(i) == top_face) continue;
    if (planes[i].n.dot(p) > planes[i].d + eps) return false;
  }
  *z = zt;
  return true;
}

std::vector<Eigen::Vector3d> Primitive::topPolygon() const {
  std::vector<Eigen::Vector3d> poly;
  if (shape != Shape::kConvex || top_face < 0) return poly;
  const HalfSpace& top = planes[top_face];
  for (const Eigen::Vector3d& v : vertices)
    if (std::abs(top.n.dot(v) - top.d) < 1e-7) poly.push_back(v);
  if (poly.empty()) return poly;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& v : poly)
    c += v;
  c /= static_cast<double>(poly.size());
  std::sort(poly.begin(), poly.end(), [&c](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::atan2(a.y() - c.y(), a.x() - c.x()) < std::atan2(b.y() - c.y(), b.x() - c.x());
  });
  return poly;
}

void Primitive::translate(const Eigen::Vector3d& offset) {
  for (HalfSpace& h : planes)
    h.d += h.n.dot(offset);
  for (Eigen::Vector3d& v : vertices)
    v += offset;
  p0 += offset;
  if (!bounds.isEmpty()) bounds.translate(offset);
  obb.center += offset;
}

int Scene::addMaterial(const std::string& name, const Material& m) {
  const int existing = findMaterial(name);
  if (existing >= 0) return existing;
  materials.push_back(m);
  material_names.push_back(name);
  return static_cast<int>(materials.size()) - 1;
}

int Scene::findMaterial(const std::string& name) const {
  for (std::size_t i = 0; i < material_names.size(); ++i)
    if (material_names[i] == name) return static_cast<int>(i);
  return -1;
}

int Scene::add(Primitive p) {
  std::string base = p.name.empty() ? (p.type.empty() ? "primitive" : p.type) : p.name;
  std::string name = base;
  for (int k = 1;; ++k) {
    bool taken = false;
    for (const Primitive& q : primitives)
      taken = taken || q.name == name;
    if (!taken) break;
    name = base + "_" + std::to_string(k);
  }
  p.name = name;
  if (p.group.empty()) p.group = name;
  primitives.push_back(std::move(p));
  return static_cast<int>(primitives.size()) - 1;
}

bool Scene::intersect(const Ray& ray, double t_min, double t_max, Hit* hit) const {
  Hit best;
  best.t = t_max;
  for (std::size_t i = 0; i < primitives.size(); ++i) {
    double tin, tout;
    int face;
    if (!primitives[i].interval(ray, &tin, &tout, &face)) continue;
    if (tin > t_min && tin < best.t) {
      best.t = tin;
      best.primitive = static_cast<int>(i);
      best.face = face;
    }
  }
  if (best.primitive < 0) return false;
  best.normal = primitives[best.primitive].normalAt(best.face, ray.origin + best.t * ray.dir);
  *hit = best;
  return true;
}

Eigen::AlignedBox3d Scene::bounds() const {
  Eigen::AlignedBox3d b;
  for (const Primitive& p : primitives)
    if (!p.bounds.isEmpty()) b.extend(p.bounds);
  return b;
}

std::string Scene::validate() const {
  std::string e = lighting.validate();
  if (!e.empty()) return e;
  if (!finite3f(sky_horizon) || !finite3f(sky_zenith)) return "sky colours must be finite";
  for (std::size_t i = 0; i < materials.size(); ++i) {
    e = materials[i].validate();
    if (!e.empty()) return "material '" + material_names[i] + "': " + e;
  }
  const int nm = static_cast<int>(materials.size());
  for (const Primitive& p : primitives) {
    const std::string who = "primitive '" + p.name + "': ";
    if (p.material < 0 || p.material >= nm) return who + "material index out of range";
    if (p.side_material < -1 || p.side_material >= nm)
      return who + "side material index out of range";
    if (p.shape == Primitive::Shape::kConvex) {
      if (p.vertices.size() < 4) return who + "half-spaces do not bound a solid";
      for (const HalfSpace& h : p.planes)
        if (!finite3(h.n) || !std::isfinite(h.d) || std::abs(h.n.norm() - 1.0) > 1e-6)
          return who + "half-space normals must be finite unit vectors";
    } else {
      if (!(std::isfinite(p.radius) && p.radius > 0.0)) return who + "radius must be > 0";
      if (!(std::isfinite(p.length) && p.length > 0.0)) return who + "length must be > 0";
      if (!finite3(p.p0) || !finite3(p.axis)) return who + "axis must be finite";
    }
    if (p.ground) {
      if (p.shape != Primitive::Shape::kConvex)
        return who + "a ground surface must be a convex solid (floor, ramp, step, box)";
      if (p.top_face < 0 || p.planes[p.top_face].n.z() < 0.5)
        return who + "a ground surface needs a top face sloping less than 60 deg";
    }
  }
  return "";
}

Eigen::Matrix3d rotationYpr(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Primitive makeConvex(const std::vector<HalfSpace>& planes_in) {
  Primitive p;
  p.shape = Primitive::Shape::kConvex;
  for (HalfSpace h : planes_in) {
    const double n = h.n.norm();
    if (!(n > 1e-12) || !std::isfinite(n) || !std::isfinite(h.d)) return p;
    h.n /= n;
    h.d /= n;
    p.planes.push_back(h);
  }
  const std::size_t m = p.planes.size();
  for (std::size_t i = 0; i < m; ++i) {
    for (std::size_t j = i + 1; j < m; ++j) {
      for (std::size_t k = j + 1; k < m; ++k) {
        Eigen::Matrix3d A;
        A.row(0) = p.planes[i].n.transpose();
        A.row(1) = p.planes[j].n.transpose();
        A.row(2) = p.planes[k].n.transpose();
        if (std::abs(A.determinant()) < 1e-9) continue;
        const Eigen::Vector3d v = A.colPivHouseholderQr().solve(
            Eigen::Vector3d(p.planes[i].d, p.planes[j].d, p.planes[k].d));
        bool inside = v.allFinite();
        for (std::size_t q = 0; q < m && inside; ++q)
          inside = p.planes[q].n.dot(v) <= p.planes[q].d + 1e-7;
        if (!inside) continue;
        bool dup = false;
        for (const auto& w : p.vertices)
          dup = dup || (w - v).norm() < 1e-7;
        if (!dup) p.vertices.push_back(v);
      }
    }
  }
  if (p.vertices.size() < 4) {
    p.vertices.clear();
    return p;
  }
  for (const auto& v : p.vertices)
    p.bounds.extend(v);
  p.obb.center = p.bounds.center();
  p.obb.half_size = 0.5 * p.bounds.sizes();
  p.obb.rotation.setIdentity();
  double best = -2.0;
  for (std::size_t i = 0; i < m; ++i) {
    if (p.planes[i].n.z() > best) {
      best = p.planes[i].n.z();
      p.top_face = static_cast<int>(i);
    }
  }
  return p;
}

Primitive makeBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size,
                  const Eigen::Matrix3d& R) {
  std::vector<HalfSpace> hs;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d a = R.col(i).normalized();
    hs.push_back({a, a.dot(center) + 0.5 * size[i]});
    hs.push_back({-a, -a.dot(center) + 0.5 * size[i]});
  }
  Primitive p = makeConvex(hs);
  p.obb.center = center;
  p.obb.half_size = 0.5 * size;
  p.obb.rotation = R;
  return p;
}

Primitive makeRamp(const Eigen::Vector2d& from, const Eigen::Vector2d& to, double width,
                   double z_from, double z_to, double thickness) {
  const double L = (to - from).norm();
  if (!(L > 1e-9) || !(width > 0.0) || !(thickness > 0.0)) return Primitive();
  const Eigen::Vector2d u = (to - from) / L;
  const Eigen::Vector2d w(-u.y(), u.x());
  const double k = (z_to - z_from) / L;
  const double z_bottom = std::min(z_from, z_to) - thickness;
  std::vector<HalfSpace> hs;
  // top: z - k * u.(p - from) <= z_from
  hs.push_back({Eigen::Vector3d(-k * u.x(), -k * u.y(), 1.0), z_from - k * u.dot(from)});
  hs.push_back({Eigen::Vector3d(-u.x(), -u.y(), 0.0), -u.dot(from)});
  hs.push_back({Eigen::Vector3d(u.x(), u.y(), 0.0), u.dot(from) + L});
  hs.push_back({Eigen::Vector3d(w.x(), w.y(), 0.0), w.dot(from) + 0.5 * width});
  hs.push_back({Eigen::Vector3d(-w.x(), -w.y(), 0.0), -w.dot(from) + 0.5 * width});
  hs.push_back({Eigen::Vector3d(0.0, 0.0, -1.0), -z_bottom});
  Primitive p = makeConvex(hs);
  if (!p.vertices.empty()) {
    Eigen::Matrix3d R;
    R.col(0) = Eigen::Vector3d(u.x(), u.y(), 0.0);
    R.col(1) = Eigen::Vector3d(w.x(), w.y(), 0.0);
    R.col(2) = Eigen::Vector3d::UnitZ();
    const Eigen::Vector2d mid = 0.5 * (from + to);
    const double z_top = std::max(z_from, z_to);
    p.obb.center = Eigen::Vector3d(mid.x(), mid.y(), 0.5 * (z_top + z_bottom));
    p.obb.half_size = Eigen::Vector3d(0.5 * L, 0.5 * width, 0.5 * (z_top - z_bottom));
    p.obb.rotation = R;
  }
  return p;
}

Primitive makeFrustum(const Eigen::Vector2d& center, double z_base,
                      const Eigen::Vector2d& base_size, const Eigen::Vector2d& top_size,
                      double height, double yaw) {
  if (!(height > 0.0) || !(base_size.minCoeff() > 0.0) || !(top_size.minCoeff() >= 0.0))
    return Primitive();
  const Eigen::Matrix3d R = rotationYpr(yaw);
  const Eigen::Vector3d c(center.x(), center.y(), 0.0);
  std::vector<HalfSpace> hs;
  for (int axis = 0; axis < 2; ++axis) {
    const double a = 0.5 * base_size[axis], at = 0.5 * top_size[axis];
    for (int sgn = -1; sgn <= 1; sgn += 2) {
      Eigen::Vector3d n_local = Eigen::Vector3d::Zero();
      n_local[axis] = sgn * height;
      n_local.z() = a - at;
      Eigen::Vector3d pt_local = Eigen::Vector3d::Zero();
      pt_local[axis] = sgn * a;
      pt_local.z() = z_base;
      const Eigen::Vector3d n = R * n_local;
      hs.push_back({n, n.dot(c + R * pt_local)});
    }
  }
  hs.push_back({Eigen::Vector3d::UnitZ(), z_base + height});
  hs.push_back({-Eigen::Vector3d::UnitZ(), -z_base});
  Primitive p = makeConvex(hs);
  if (!p.vertices.empty()) {
    p.obb.rotation = R;
    p.obb.center = Eigen::Vector3d(center.x(), center.y(), z_base + 0.5 * height);
    p.obb.half_size = Eigen::Vector3d(0.5 * std::max(base_size.x(), top_size.x()),
                                      0.5 * std::max(base_size.y(), top_size.y()), 0.5 * height);
  }
  return p;
}

Primitive makeSlab(const std::vector<Eigen::Vector3d>& top_in, double thickness) {
  if (!(thickness > 0.0) || !std::isfinite(thickness)) return Primitive();
  // Drop repeated corners (a closing corner equal to the first one included).
  std::vector<Eigen::Vector3d> top;
  for (const Eigen::Vector3d& v : top_in) {
    if (!v.allFinite()) return Primitive();
    if (top.empty() || (v - top.back()).head<2>().norm() > 1e-9) top.push_back(v);
  }
  while (top.size() > 1 && (top.front() - top.back()).head<2>().norm() <= 1e-9)
    top.pop_back();
  const std::size_t n = top.size();
  if (n < 3) return Primitive();
  // Newell's normal of the polygon; counter-clockwise seen from above gives n.z > 0.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& a = top[i];
    const Eigen::Vector3d& b = top[(i + 1) % n];
    normal += Eigen::Vector3d((a.y() - b.y()) * (a.z() + b.z()), (a.z() - b.z()) * (a.x() + b.x()),
                              (a.x() - b.x()) * (a.y() + b.y()));
    centroid += a;
  }
  centroid /= static_cast<double>(n);
  const double sign = normal.z() < 0.0 ? -1.0 : 1.0;
  normal *= sign;
  if (!(normal.norm() > 1e-12)) return Primitive();
  normal.normalize();
  if (normal.z() < 0.05) return Primitive();  // (nearly) vertical: not a slab top
  for (const Eigen::Vector3d& v : top)
    if (std::abs(normal.dot(v - centroid)) > 1e-3) return Primitive();  // not planar
  // Convex in plan: every turn has the orientation of the polygon (collinear corners allowed).
  double area2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = top[i].head<2>(), b = top[(i + 1) % n].head<2>(),
                          c = top[(i + 2) % n].head<2>();
    const Eigen::Vector2d e1 = b - a, e2 = c - b;
    if (sign * (e1.x() * e2.y() - e1.y() * e2.x()) < -1e-9 * e1.norm() * e2.norm())
      return Primitive();
    area2 += a.x() * b.y() - b.x() * a.y();
  }
  if (!(std::abs(area2) > 1e-9)) return Primitive();
  double z_min = top[0].z();
  for (const Eigen::Vector3d& v : top)
    z_min = std::min(z_min, v.z());
  std::vector<HalfSpace> hs;
  hs.push_back({normal, normal.dot(centroid)});
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = top[i].head<2>(), b = top[(i + 1) % n].head<2>();
    const Eigen::Vector2d e = (b - a).normalized();
    // Outward normal of the edge: right of the edge for a counter-clockwise polygon.
    const Eigen::Vector2d out = sign * Eigen::Vector2d(e.y(), -e.x());
    hs.push_back({Eigen::Vector3d(out.x(), out.y(), 0.0), out.dot(a)});
  }
  hs.push_back({-Eigen::Vector3d::UnitZ(), -(z_min - thickness)});
  return makeConvex(hs);
}

Primitive makeCylinder(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double radius) {
  Primitive p;
  p.shape = Primitive::Shape::kCylinder;
  const double L = (p1 - p0).norm();
  p.p0 = p0;
  p.length = L;
  p.radius = radius;
  if (!(L > 1e-12) || !(radius > 0.0) || !p0.allFinite() || !p1.allFinite()) {
    p.length = 0.0;
    return p;
  }
  p.axis = (p1 - p0) / L;
  for (const Eigen::Vector3d& e : {p0, p1}) {
    Eigen::Vector3d ext;
    for (int i = 0; i < 3; ++i)
      ext[i] = radius * std::sqrt(std::max(0.0, 1.0 - p.axis[i] * p.axis[i]));
    p.bounds.extend(Eigen::Vector3d(e - ext));
    p.bounds.extend(Eigen::Vector3d(e + ext));
  }
  p.obb.center = 0.5 * (p0 + p1);
  p.obb.half_size = Eigen::Vector3d(radius, radius, 0.5 * L);
  p.obb.rotation = basisAround(p.axis);
  return p;
}

}  // namespace dataset
}  // namespace stereo_safety_map
