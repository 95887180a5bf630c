#include "stereo_safety_map/dataset/scene_loader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {
namespace dataset {

namespace {

constexpr double kDeg = M_PI / 180.0;

struct LoadError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string where(const YAML::Node& n) {
  const YAML::Mark m = n.Mark();
  if (m.is_null()) return "";
  return " (line " + std::to_string(m.line + 1) + ")";
}

std::uint32_t fnv1a(const std::string& s) {
  std::uint32_t h = 2166136261u;
  for (unsigned char c : s) {
    h ^= c;
    h *= 16777619u;
  }
  return h;
}

// A YAML map read key by key; finish() rejects keys nobody asked for (typos).
class Fields {
 public:
  Fields(const YAML::Node& node, std::string ctx) : n_(node), ctx_(std::move(ctx)) {
    if (!n_.IsMap()) throw LoadError(ctx_ + ": expected a map" + where(n_));
  }

  bool has(const std::string& key) {
    used_.insert(key);
    return static_cast<bool>(n_[key]);
  }
  YAML::Node node(const std::string& key) {
    used_.insert(key);
    return n_[key];
  }
  std::string name(const std::string& key) const { return ctx_ + "." + key; }

  double num(const std::string& key, double def) { return has(key) ? toNum(n_[key], key) : def; }
  double numReq(const std::string& key) {
    if (!has(key)) throw LoadError(ctx_ + ": missing '" + key + "'" + where(n_));
    return toNum(n_[key], key);
  }
  int integer(const std::string& key, int def) {
    const double v = num(key, def);
    if (v != std::floor(v) || std::abs(v) > 1e9)
      throw LoadError(name(key) + ": expected an integer" + where(n_[key]));
    return static_cast<int>(v);
  }
  bool flag(const std::string& key, bool def) {
    if (!has(key)) return def;
    try {
      return n_[key].as<bool>();
    } catch (const YAML::Exception&) {
      throw LoadError(name(key) + ": expected true or false" + where(n_[key]));
    }
  }
  std::string str(const std::string& key, const std::string& def) {
    if (!has(key)) return def;
    if (!n_[key].IsScalar()) throw LoadError(name(key) + ": expected a string" + where(n_[key]));
    return n_[key].as<std::string>();
  }
  Eigen::VectorXd vec(const std::string& key, int size) {
    if (!has(key)) throw LoadError(ctx_ + ": missing '" + key + "'" + where(n_));
    const YAML::Node v = n_[key];
    if (!v.IsSequence() || static_cast<int>(v.size()) != size)
      throw LoadError(name(key) + ": expected a list of " + std::to_string(size) + " numbers" +
                      where(v));
    Eigen::VectorXd out(size);
    for (int i = 0; i < size; ++i)
      out[i] = toNum(v[i], key);
    return out;
  }
  Eigen::Vector2d vec2(const std::string& key) { return vec(key, 2); }
  Eigen::Vector2d vec2(const std::string& key, const Eigen::Vector2d& def) {
    return has(key) ? Eigen::Vector2d(vec(key, 2)) : def;
  }
  Eigen::Vector3d vec3(const std::string& key) { return vec(key, 3); }
  Eigen::Vector3d vec3(const std::string& key, const Eigen::Vector3d& def) {
    return has(key) ? Eigen::Vector3d(vec(key, 3)) : def;
  }
  // [r, g, b] in [0, 1] or in [0, 255], or a single grey value.
  Eigen::Vector3f colour(const std::string& key, const Eigen::Vector3f& def) {
    if (!has(key)) return def;
    const YAML::Node v = n_[key];
    Eigen::Vector3d c;
    if (v.IsScalar()) {
      c.setConstant(toNum(v, key));
    } else {
      c = vec(key, 3);
    }
    if (c.maxCoeff() > 1.0) c /= 255.0;
    if (!c.allFinite() || c.minCoeff() < 0.0 || c.maxCoeff() > 1.0)
      throw LoadError(name(key) + ": colour components must be in [0, 1] or [0, 255]" + where(v));
    return c.cast<float>();
  }

  void finish() const {
    for (const auto& kv : n_) {
      const std::string k = kv.first.as<std::string>();
      if (!used_.count(k)) throw LoadError(ctx_ + ": unknown key '" + k + "'" + where(kv.first));
    }
  }

 private:
  double toNum(const YAML::Node& v, const std::string& key) const {
    double d;
    try {
      d = v.as<double>();
    } catch (const YAML::Exception&) {
      throw LoadError(name(key) + ": expected a number" + where(v));
    }
    if (!std::isfinite(d)) throw LoadError(name(key) + ": must be finite" + where(v));
    return d;
  }

  YAML::Node n_;
  std::string ctx_;
  std::set<std::string> used_;
};

YAML::Node mergeNodes(const YAML::Node& base, const YAML::Node& over) {
  if (!base.IsMap() || !over.IsMap()) return YAML::Clone(over);
  YAML::Node out = YAML::Clone(base);
  for (const auto& kv : over) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& cout = out;
    if (cout[key]) {
      out[key] = mergeNodes(cout[key], kv.second);
    } else {
      out[key] = YAML::Clone(kv.second);
    }
  }
  return out;
}

Material parseMaterial(const YAML::Node& node, const std::string& ctx, const std::string& name) {
  Fields f(node, ctx);
  Material m;
  const std::string tex = f.str("texture", toString(m.texture));
  if (!parseTextureKind(tex, &m.texture))
    throw LoadError(f.name("texture") + ": unknown texture '" + tex +
                    "' (plain, noise, speckle, tiles, bricks, stripes, checker)");
  m.scale = f.num("scale", m.scale);
  m.contrast = f.num("contrast", m.contrast);
  m.colour = f.colour("colour", m.colour);
  m.line_width = f.num("line_width", m.line_width);
  m.detail = f.num("detail", m.detail);
  m.grain = f.num("grain", m.grain);
  m.grain_size = f.num("grain_size", m.grain_size);
  m.angle_deg = f.num("angle_deg", m.angle_deg);
  m.seed = f.has("seed") ? static_cast<std::uint32_t>(f.integer("seed", 0)) : fnv1a(name);
  f.finish();
  const std::string e = m.validate();
  if (!e.empty()) throw LoadError(ctx + ": " + e);
  return m;
}

// A primitive's material: the name of a material of the file or an inline map.
int materialRef(Scene* scene, Fields& f, const std::string& key, const std::string& owner,
                int def) {
  if (!f.has(key)) return def;
  const YAML::Node v = f.node(key);
  if (v.IsScalar()) {
    const int idx = scene->findMaterial(v.as<std::string>());
    if (idx < 0)
      throw LoadError(f.name(key) + ": no material named '" + v.as<std::string>() + "'" + where(v));
    return idx;
  }
  const std::string mname = owner + "/" + key;
  return scene->addMaterial(mname, parseMaterial(v, f.name(key), mname));
}

int defaultMaterial(Scene* scene) {
  const int existing = scene->findMaterial("default");
  if (existing >= 0) return existing;
  Material m;
  m.seed = fnv1a("default");
  return scene->addMaterial("default", m);
}

void checkSolid(const Primitive& p, const std::string& ctx) {
  if (p.shape == Primitive::Shape::kConvex && p.vertices.size() < 4)
    throw LoadError(ctx + ": degenerate solid (check sizes, widths and heights)");
  if (p.shape == Primitive::Shape::kCylinder && !(p.length > 0.0 && p.radius > 0.0))
    throw LoadError(ctx + ": degenerate cylinder (check radius and end points)");
}

double positive(Fields& f, const std::string& key, double def) {
  const double v = f.num(key, def);
  if (!(v > 0.0)) throw LoadError(f.name(key) + ": must be > 0");
  return v;
}

// One [x, y] or [x, y, z] point of a list.
Eigen::VectorXd pointOf(const YAML::Node& v, const std::string& ctx, int size) {
  if (!v.IsSequence() || static_cast<int>(v.size()) != size)
    throw LoadError(ctx + ": expected points of " + std::to_string(size) + " numbers" + where(v));
  Eigen::VectorXd out(size);
  for (int i = 0; i < size; ++i) {
    try {
      out[i] = v[i].as<double>();
    } catch (const YAML::Exception&) {
      throw LoadError(ctx + ": expected a number" + where(v[i]));
    }
    if (!std::isfinite(out[i])) throw LoadError(ctx + ": must be finite" + where(v[i]));
  }
  return out;
}

// Expands one `primitives` entry into solids.
std::vector<Primitive> buildEntry(Scene* scene, const YAML::Node& node, const std::string& ctx,
                                  int index) {
  Fields f(node, ctx);
  const std::string type = f.str("type", "");
  if (type.empty()) throw LoadError(ctx + ": missing 'type'" + where(node));
  const std::string name = f.str("name", type + std::to_string(index));
  const int material = materialRef(scene, f, "material", name, defaultMaterial(scene));
  const int side_material = materialRef(scene, f, "side_material", name, -1);
  std::vector<Primitive> out;
  bool ground_default = false;

  if (type == "floor" || type == "platform") {
    ground_default = true;
    const double z = f.num("z", 0.0), th = positive(f, "thickness", 0.3);
    Eigen::Vector2d c = Eigen::Vector2d::Zero(), size = Eigen::Vector2d::Zero();
    double yaw = 0.0;
    if (f.has("polygon")) {
      // A convex polygon (the floor around a sunken area cut at an angle).
      const YAML::Node poly = f.node("polygon");
      if (!poly.IsSequence() || poly.size() < 3)
        throw LoadError(f.name("polygon") + ": expected a list of at least 3 [x, y]" + where(poly));
      std::vector<Eigen::Vector3d> top;
      for (std::size_t i = 0; i < poly.size(); ++i) {
        const Eigen::Vector2d v = pointOf(poly[i], f.name("polygon"), 2);
        top.emplace_back(v.x(), v.y(), z);
      }
      if (f.has("min") || f.has("max") || f.has("center") || f.has("size"))
        throw LoadError(ctx + ": give either polygon, min/max or center/size");
      Primitive p = makeSlab(top, th);
      if (p.vertices.empty())
        throw LoadError(f.name("polygon") + ": must be a convex polygon with a positive area");
      out.push_back(p);
    } else if (f.has("min") || f.has("max")) {
      const Eigen::Vector2d lo = f.vec2("min"), hi = f.vec2("max");
      c = 0.5 * (lo + hi);
      size = hi - lo;
    } else {
      c = f.vec2("center");
      size = f.vec2("size");
      yaw = f.num("yaw_deg", 0.0) * kDeg;
    }
    if (out.empty()) {
      if (!(size.minCoeff() > 0.0)) throw LoadError(ctx + ": floor extent must be positive");
      out.push_back(makeBox(Eigen::Vector3d(c.x(), c.y(), z - 0.5 * th),
                            Eigen::Vector3d(size.x(), size.y(), th), rotationYpr(yaw)));
    }
  } else if (type == "ramp") {
    ground_default = true;
    const Eigen::Vector2d from = f.vec2("from"), to = f.vec2("to");
    const double width = positive(f, "width", 1.0), th = positive(f, "thickness", 0.3);
    const double z_from = f.num("z_from", 0.0);
    double z_to;
    if (f.has("slope_deg")) {
      if (f.has("z_to")) throw LoadError(ctx + ": give either z_to or slope_deg, not both");
      const double s = f.num("slope_deg", 0.0);
      if (!(std::abs(s) < 60.0)) throw LoadError(f.name("slope_deg") + ": must be in (-60, 60)");
      z_to = z_from + (to - from).norm() * std::tan(s * kDeg);
    } else {
      z_to = f.num("z_to", z_from);
    }
    out.push_back(makeRamp(from, to, width, z_from, z_to, th));
  } else if (type == "slab") {
    ground_default = true;
    const YAML::Node poly = f.node("top");
    if (!poly || !poly.IsSequence() || poly.size() < 3)
      throw LoadError(f.name("top") + ": expected a list of at least 3 [x, y, z]" + where(node));
    std::vector<Eigen::Vector3d> top;
    for (std::size_t i = 0; i < poly.size(); ++i)
      top.push_back(pointOf(poly[i], f.name("top"), 3));
    Primitive p = makeSlab(top, positive(f, "thickness", 0.3));
    if (p.vertices.empty())
      throw LoadError(
          f.name("top") +
          ": must be a planar (1 mm) convex polygon, not vertical, with a positive area");
    out.push_back(p);
  } else if (type == "stairs" || type == "steps") {
    ground_default = true;
    const Eigen::Vector2d from = f.vec2("from");
    const double dir = f.num("direction_deg", 0.0) * kDeg;
    const double width = positive(f, "width", 1.2), run = positive(f, "run", 0.3);
    const int count = f.integer("count", 3);
    const double rise = f.num("rise", 0.15), z_from = f.num("z_from", 0.0);
    const double landing = f.num("landing", 0.0), th = positive(f, "thickness", 0.3);
    if (count < 1 || count > 200) throw LoadError(f.name("count") + ": must be in [1, 200]");
    if (landing < 0.0) throw LoadError(f.name("landing") + ": must be >= 0");
    const Eigen::Vector2d u(std::cos(dir), std::sin(dir));
    const double z_last = z_from + count * rise;
    const double z_bottom = std::min(z_from, z_last) - th;
    for (int i = 0; i < count; ++i) {
      const double len = run + (i == count - 1 ? landing : 0.0);
      const double z_top = z_from + (i + 1) * rise;
      const Eigen::Vector2d c = from + u * (i * run + 0.5 * len);
      Primitive p = makeBox(Eigen::Vector3d(c.x(), c.y(), 0.5 * (z_top + z_bottom)),
                            Eigen::Vector3d(len, width, z_top - z_bottom), rotationYpr(dir));
      p.name = name + "_step" + std::to_string(i + 1);
      out.push_back(p);
    }
  } else if (type == "box" || type == "board") {
    const Eigen::Vector3d size = f.vec3("size");
    if (!(size.minCoeff() > 0.0)) throw LoadError(f.name("size") + ": must be positive");
    Eigen::Vector3d c;
    if (f.has("base")) {
      if (f.has("center")) throw LoadError(ctx + ": give either base or center, not both");
      c = f.vec3("base") + Eigen::Vector3d(0.0, 0.0, 0.5 * size.z());
    } else {
      c = f.vec3("center");
    }
    const Eigen::Matrix3d R =
        rotationYpr(f.num("yaw_deg", 0.0) * kDeg, f.num("pitch_deg", 0.0) * kDeg,
                    f.num("roll_deg", 0.0) * kDeg);
    out.push_back(makeBox(c, size, R));
  } else if (type == "wall") {
    const Eigen::Vector2d a = f.vec2("from"), b = f.vec2("to");
    const double h = positive(f, "height", 2.5), th = positive(f, "thickness", 0.15);
    const double z = f.num("z", 0.0);
    const double L = (b - a).norm();
    if (!(L > 0.0)) throw LoadError(ctx + ": wall from and to must differ");
    const Eigen::Vector2d c = 0.5 * (a + b);
    out.push_back(makeBox(Eigen::Vector3d(c.x(), c.y(), z + 0.5 * h), Eigen::Vector3d(L, th, h),
                          rotationYpr(std::atan2(b.y() - a.y(), b.x() - a.x()))));
  } else if (type == "pole") {
    const Eigen::Vector2d at = f.vec2("at");
    const double r = positive(f, "radius", 0.05), h = positive(f, "height", 2.5);
    const double z = f.num("z", 0.0);
    out.push_back(makeCylinder(Eigen::Vector3d(at.x(), at.y(), z),
                               Eigen::Vector3d(at.x(), at.y(), z + h), r));
  } else if (type == "cylinder") {
    out.push_back(makeCylinder(f.vec3("from"), f.vec3("to"), positive(f, "radius", 0.05)));
  } else if (type == "mound" || type == "frustum") {
    const Eigen::Vector2d base = f.vec2("base_size");
    const Eigen::Vector2d top = f.vec2("top_size", 0.5 * base);
    out.push_back(makeFrustum(f.vec2("center"), f.num("z", 0.0), base, top,
                              positive(f, "height", 0.5), f.num("yaw_deg", 0.0) * kDeg));
  } else if (type == "table") {
    const Eigen::Vector2d c = f.vec2("center"), size = f.vec2("size");
    const double h = positive(f, "height", 0.75), tt = positive(f, "top_thickness", 0.04);
    const double lr = positive(f, "leg_radius", 0.025), inset = f.num("leg_inset", 0.05);
    const double z = f.num("z", 0.0), yaw = f.num("yaw_deg", 0.0) * kDeg;
    if (!(size.minCoeff() > 2.0 * (inset + lr)) || !(h > tt))
      throw LoadError(ctx + ": table too small for its legs or thinner than its top");
    const Eigen::Matrix3d R = rotationYpr(yaw);
    Primitive top = makeBox(Eigen::Vector3d(c.x(), c.y(), z + h - 0.5 * tt),
                            Eigen::Vector3d(size.x(), size.y(), tt), R);
    top.name = name + "_top";
    out.push_back(top);
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d off((k & 1 ? 1 : -1) * (0.5 * size.x() - inset - lr),
                                (k & 2 ? 1 : -1) * (0.5 * size.y() - inset - lr), 0.0);
      const Eigen::Vector3d p = Eigen::Vector3d(c.x(), c.y(), z) + R * off;
      Primitive leg = makeCylinder(p, p + Eigen::Vector3d(0, 0, h - tt), lr);
      leg.name = name + "_leg" + std::to_string(k + 1);
      out.push_back(leg);
    }
  } else if (type == "railing" || type == "fence") {
    const Eigen::Vector2d a = f.vec2("from"), b = f.vec2("to");
    const double z_from = f.num("z_from", f.num("z", 0.0));
    const double z_to = f.num("z_to", z_from);
    const double h = positive(f, "height", 0.9);
    const double spacing = positive(f, "post_spacing", 1.2);
    const double post_r = positive(f, "post_radius", 0.025);
    const double rail_r = positive(f, "rail_radius", 0.025);
    const int mid_rails = f.integer("mid_rails", 1);
    const double picket_spacing = f.num("picket_spacing", 0.0);
    const double picket_r = positive(f, "picket_radius", 0.012);
    const double picket_w = f.num("picket_width", 0.0);
    const double picket_t = positive(f, "picket_thickness", 0.02);
    const double L = (b - a).norm();
    if (!(L > 0.0)) throw LoadError(ctx + ": railing from and to must differ");
    if (mid_rails < 0 || mid_rails > 10) throw LoadError(f.name("mid_rails") + ": in [0, 10]");
    if (picket_spacing < 0.0 || (picket_spacing > 0.0 && picket_spacing < 0.03))
      throw LoadError(f.name("picket_spacing") + ": 0 (none) or >= 0.03 [m]");
    auto at = [&](double s) {  // base point at arc length s
      const Eigen::Vector2d p = a + (b - a) * (s / L);
      return Eigen::Vector3d(p.x(), p.y(), z_from + (z_to - z_from) * (s / L));
    };
    const Eigen::Vector3d up(0, 0, 1);
    const int posts = static_cast<int>(std::ceil(L / spacing - 1e-9)) + 1;
    for (int i = 0; i < posts; ++i) {
      const Eigen::Vector3d p = at(L * i / (posts - 1));
      Primitive post = makeCylinder(p, p + up * h, post_r);
      post.name = name + "_post" + std::to_string(i + 1);
      out.push_back(post);
    }
    for (int r = 0; r <= mid_rails; ++r) {
      const double hr = h * (mid_rails + 1 - r) / (mid_rails + 1);
      Primitive rail = makeCylinder(at(0.0) + up * hr, at(L) + up * hr, rail_r);
      rail.name = name + (r == 0 ? "_top_rail" : "_rail" + std::to_string(r));
      out.push_back(rail);
    }
    if (picket_spacing > 0.0) {
      const int n = static_cast<int>(std::floor(L / picket_spacing));
      const double yaw = std::atan2(b.y() - a.y(), b.x() - a.x());
      for (int i = 1; i < n; ++i) {
        const Eigen::Vector3d p = at(i * picket_spacing);
        Primitive pk;
        if (picket_w > 0.0) {
          pk = makeBox(p + up * (0.5 * h), Eigen::Vector3d(picket_w, picket_t, h - 0.05),
                       rotationYpr(yaw));
        } else {
          pk = makeCylinder(p + up * 0.05, p + up * h, picket_r);
        }
        pk.name = name + "_picket" + std::to_string(i);
        out.push_back(pk);
      }
    }
  } else {
    throw LoadError(ctx + ": unknown type '" + type +
                    "' (floor, platform, slab, ramp, stairs, box, board, wall, pole, cylinder, "
                    "mound, table, railing)");
  }

  const bool ground = f.flag("ground", ground_default);
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  int repeat = 1;
  if (f.has("repeat")) {
    Fields r(f.node("repeat"), f.name("repeat"));
    repeat = r.integer("count", 1);
    offset = r.vec3("offset");
    r.finish();
    if (repeat < 1 || repeat > 1000) throw LoadError(f.name("repeat") + ".count: in [1, 1000]");
  }
  f.finish();

  std::vector<Primitive> all;
  for (int k = 0; k < repeat; ++k) {
    for (Primitive p : out) {
      checkSolid(p, ctx);
      if (p.name.empty()) p.name = name;
      if (repeat > 1) p.name += "_r" + std::to_string(k + 1);
      p.group = repeat > 1 ? name + "_r" + std::to_string(k + 1) : name;
      p.type = type;
      p.ground = ground;
      p.material = material;
      p.side_material = side_material;
      if (ground && (p.shape != Primitive::Shape::kConvex || p.planes[p.top_face].n.z() < 0.5))
        throw LoadError(ctx + ": only convex solids with a top sloping < 60 deg can be ground");
      p.translate(offset * k);
      all.push_back(std::move(p));
    }
  }
  return all;
}

void parseTrajectory(const YAML::Node& node, TrajectoryConfig* t, bool* has_base_z) {
  Fields f(node, "trajectory");
  t->rate_hz = f.num("rate_hz", t->rate_hz);
  const Eigen::Vector3d start = f.vec3("start", Eigen::Vector3d(0, 0, 0));
  t->start_x = start.x();
  t->start_y = start.y();
  t->start_yaw_deg = start.z();
  *has_base_z = f.has("base_z");
  t->base_z = f.num("base_z", 0.0);
  t->speed = f.num("speed", t->speed);
  t->turn_rate_deg = f.num("turn_rate_deg", t->turn_rate_deg);
  t->steps.clear();
  if (f.has("steps")) {
    const YAML::Node steps = f.node("steps");
    if (!steps.IsSequence()) throw LoadError("trajectory.steps: expected a list" + where(steps));
    for (std::size_t i = 0; i < steps.size(); ++i) {
      Fields s(steps[i], "trajectory.steps[" + std::to_string(i) + "]");
      TrajectoryStep st;
      int kinds = 0;
      if (s.has("pause")) {
        st.kind = TrajectoryStep::Kind::kPause;
        st.value = s.num("pause", 0.0);
        ++kinds;
      }
      if (s.has("go")) {
        st.kind = TrajectoryStep::Kind::kGo;
        const Eigen::Vector2d g = s.vec2("go");
        st.x = g.x();
        st.y = g.y();
        st.speed = s.num("speed", 0.0);
        ++kinds;
      }
      if (s.has("back")) {
        st.kind = TrajectoryStep::Kind::kBack;
        const Eigen::Vector2d g = s.vec2("back");
        st.x = g.x();
        st.y = g.y();
        st.speed = s.num("speed", 0.0);
        ++kinds;
      }
      if (s.has("turn_to")) {
        st.kind = TrajectoryStep::Kind::kTurnTo;
        st.value = s.num("turn_to", 0.0);
        ++kinds;
      }
      if (s.has("turn_by")) {
        st.kind = TrajectoryStep::Kind::kTurnBy;
        st.value = s.num("turn_by", 0.0);
        ++kinds;
      }
      if (kinds != 1)
        throw LoadError("trajectory.steps[" + std::to_string(i) +
                        "]: exactly one of pause, go, back, turn_to, turn_by" + where(steps[i]));
      s.finish();
      t->steps.push_back(st);
    }
  }
  f.finish();
  const std::string e = t->validate();
  if (!e.empty()) throw LoadError(e);
}

void parseDocument(const YAML::Node& root, SceneFile* out) {
  Fields f(root, "scene");
  Scene& scene = out->scene;
  scene.name = f.str("name", "scene");
  scene.description = f.str("description", "");
  const std::string look = f.str("look", "indoor");
  if (look != "indoor" && look != "outdoor")
    throw LoadError("scene.look: 'indoor' or 'outdoor', not '" + look + "'");
  scene.outdoor = look == "outdoor";
  if (scene.outdoor) {  // sun and sky
    scene.lighting.direction = Eigen::Vector3d(0.4, 0.3, -0.8);
    scene.lighting.ambient = 0.45;
    scene.lighting.diffuse = 0.65;
    scene.sky_horizon = Eigen::Vector3f(0.82f, 0.86f, 0.92f);
    scene.sky_zenith = Eigen::Vector3f(0.50f, 0.62f, 0.85f);
  } else {  // ceiling lights: mostly from above, dim uniform background
    scene.lighting.direction = Eigen::Vector3d(0.15, 0.1, -1.0);
    scene.lighting.ambient = 0.5;
    scene.lighting.diffuse = 0.45;
    scene.sky_horizon = Eigen::Vector3f(0.55f, 0.55f, 0.55f);
    scene.sky_zenith = Eigen::Vector3f(0.6f, 0.6f, 0.6f);
  }
  out->seed = static_cast<std::uint64_t>(f.integer("seed", 1));
  if (f.has("lighting")) {
    Fields l(f.node("lighting"), "lighting");
    scene.lighting.direction = l.vec3("direction", scene.lighting.direction);
    scene.lighting.ambient = l.num("ambient", scene.lighting.ambient);
    scene.lighting.diffuse = l.num("diffuse", scene.lighting.diffuse);
    l.finish();
  }
  if (f.has("sky")) {
    Fields s(f.node("sky"), "sky");
    scene.sky_horizon = s.colour("horizon", scene.sky_horizon);
    scene.sky_zenith = s.colour("zenith", scene.sky_zenith);
    s.finish();
  }
  if (f.has("camera")) {
    Fields c(f.node("camera"), "camera");
    StereoHeadConfig& h = out->camera;
    h.width = c.integer("width", h.width);
    h.height = c.integer("height", h.height);
    h.hfov_deg = c.num("hfov_deg", h.hfov_deg);
    h.baseline = c.num("baseline", h.baseline);
    const Eigen::Vector3d m = c.vec3("mount", Eigen::Vector3d(h.mount_x, h.mount_y, h.mount_z));
    h.mount_x = m.x();
    h.mount_y = m.y();
    h.mount_z = m.z();
    h.pitch_deg = c.num("pitch_deg", h.pitch_deg);
    h.exposure = c.num("exposure", h.exposure);
    h.noise_sigma = c.num("noise_sigma", h.noise_sigma);
    h.blur_sigma = c.num("blur_sigma", h.blur_sigma);
    h.right_gain = c.num("right_gain", h.right_gain);
    h.colour = c.flag("colour", h.colour);
    c.finish();
  }
  {
    const std::string e = out->camera.validate();
    if (!e.empty()) throw LoadError(e);
  }
  if (f.has("laser")) {
    Fields c(f.node("laser"), "laser");
    LaserConfig& l = out->laser;
    const Eigen::Vector3d m = c.vec3("mount", Eigen::Vector3d(l.mount_x, l.mount_y, l.mount_z));
    l.mount_x = m.x();
    l.mount_y = m.y();
    l.mount_z = m.z();
    l.angle_min_deg = c.num("angle_min_deg", l.angle_min_deg);
    l.angle_max_deg = c.num("angle_max_deg", l.angle_max_deg);
    l.angle_increment_deg = c.num("angle_increment_deg", l.angle_increment_deg);
    l.range_min = c.num("range_min", l.range_min);
    l.range_max = c.num("range_max", l.range_max);
    l.noise_sigma = c.num("noise_sigma", l.noise_sigma);
    c.finish();
    const std::string e = l.validate();
    if (!e.empty()) throw LoadError(e);
  }
  if (f.has("materials")) {
    const YAML::Node mats = f.node("materials");
    if (!mats.IsMap()) throw LoadError("materials: expected a map of name: material" + where(mats));
    for (const auto& kv : mats) {
      const std::string name = kv.first.as<std::string>();
      if (scene.findMaterial(name) >= 0) throw LoadError("materials: duplicate '" + name + "'");
      scene.addMaterial(name, parseMaterial(kv.second, "materials." + name, name));
    }
  }
  if (!f.has("primitives")) throw LoadError("scene: missing 'primitives'");
  const YAML::Node prims = f.node("primitives");
  if (!prims.IsSequence()) throw LoadError("primitives: expected a list" + where(prims));
  for (std::size_t i = 0; i < prims.size(); ++i) {
    const std::string ctx = "primitives[" + std::to_string(i) + "]";
    for (Primitive& p : buildEntry(&scene, prims[i], ctx, static_cast<int>(i))) {
      for (const Primitive& q : scene.primitives)
        if (q.name == p.name) throw LoadError(ctx + ": duplicate name '" + p.name + "'");
      scene.add(std::move(p));
    }
  }
  bool has_base_z = false;
  if (f.has("trajectory")) parseTrajectory(f.node("trajectory"), &out->trajectory, &has_base_z);
  f.has("variants");  // consumed by the caller
  f.finish();
  if (!has_base_z) {
    double z;
    if (groundHeightAt(scene, out->trajectory.start_x, out->trajectory.start_y, &z))
      out->trajectory.base_z = z;
  }
  const std::string e = scene.validate();
  if (!e.empty()) throw LoadError(e);
}

}  // namespace

bool groundHeightAt(const Scene& scene, double x, double y, double* z) {
  bool found = false;
  double best = -std::numeric_limits<double>::infinity();
  for (const Primitive& p : scene.primitives) {
    double h;
    if (p.ground && p.topHeightAt(x, y, &h, 1e-9) && h > best) {
      best = h;
      found = true;
    }
  }
  if (found) *z = best;
  return found;
}

std::string loadSceneFromString(const std::string& yaml, const std::string& variant,
                                SceneFile* out) {
  try {
    YAML::Node root = YAML::Load(yaml);
    if (!root.IsMap()) return "scene file: expected a YAML map at the top level";
    SceneFile result;
    const YAML::Node& croot = root;
    if (croot["variants"]) {
      const YAML::Node vars = croot["variants"];
      if (!vars.IsMap()) return "variants: expected a map of name: overrides" + where(vars);
      for (const auto& kv : vars)
        result.variants.push_back(kv.first.as<std::string>());
    }
    YAML::Node doc = root;
    if (!variant.empty()) {
      if (std::find(result.variants.begin(), result.variants.end(), variant) ==
          result.variants.end())
        return "scene has no variant '" + variant + "'";
      const YAML::Node over = croot["variants"][variant];
      if (!over.IsMap()) return "variants." + variant + ": expected a map" + where(over);
      doc = mergeNodes(root, over);
    }
    parseDocument(doc, &result);
    if (!variant.empty()) {
      result.variant = variant;
      result.scene.name += "_" + variant;
    }
    *out = std::move(result);
    return "";
  } catch (const LoadError& e) {
    return e.what();
  } catch (const YAML::Exception& e) {
    return std::string("YAML: ") + e.what();
  }
}

std::string loadSceneFromFile(const std::string& path, const std::string& variant, SceneFile* out) {
  std::ifstream f(path);
  if (!f) return "cannot open scene file " + path;
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string e = loadSceneFromString(ss.str(), variant, out);
  return e.empty() ? e : path + ": " + e;
}

}  // namespace dataset
}  // namespace stereo_safety_map
