#include "stereo_safety_map/dataset/renderer.h"

#include "stereo_safety_map/dataset/texture.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <random>
#include <stdexcept>
#include <thread>

namespace stereo_safety_map {
namespace dataset {

namespace {

constexpr int kTile = 16;
constexpr double kDeg = M_PI / 180.0;

// Runs fn(i) for i in [0, n) on `threads` threads (the calling one included).
void parallelFor(int n, int threads, const std::function<void(int)>& fn) {
  threads = std::max(1, std::min(threads, n));
  if (threads == 1) {
    for (int i = 0; i < n; ++i)
      fn(i);
    return;
  }
  std::atomic<int> next{0};
  auto worker = [&]() {
    for (int i = next++; i < n; i = next++)
      fn(i);
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (int k = 1; k < threads; ++k)
    pool.emplace_back(worker);
  worker();
  for (auto& t : pool)
    t.join();
}

inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace

std::string StereoHeadConfig::validate() const {
  if (width < 16 || width > 8192) return "camera.width must be in [16, 8192] [px]";
  if (height < 16 || height > 8192) return "camera.height must be in [16, 8192] [px]";
  if (!(hfov_deg >= 20.0 && hfov_deg <= 120.0)) return "camera.hfov_deg must be in [20, 120]";
  if (!(baseline > 0.0 && baseline <= 1.0)) return "camera.baseline must be in (0, 1] [m]";
  if (!std::isfinite(mount_x) || !std::isfinite(mount_y) || !std::isfinite(mount_z))
    return "camera.mount must be finite";
  if (!(pitch_deg >= -10.0 && pitch_deg <= 80.0)) return "camera.pitch_deg must be in [-10, 80]";
  if (!(near_clip > 0.0 && near_clip < 10.0)) return "camera.near_clip must be in (0, 10) [m]";
  if (!(max_depth > near_clip && max_depth <= 1e5))
    return "camera.max_depth must be in (near_clip, 1e5] [m]";
  if (!(exposure > 0.0 && exposure <= 10.0)) return "camera.exposure must be in (0, 10]";
  if (!(noise_sigma >= 0.0 && noise_sigma <= 50.0))
    return "camera.noise_sigma must be in [0, 50] [grey levels]";
  if (!(blur_sigma >= 0.0 && blur_sigma <= 5.0)) return "camera.blur_sigma must be in [0, 5] [px]";
  if (!(right_gain >= 0.5 && right_gain <= 2.0)) return "camera.right_gain must be in [0.5, 2]";
  if (threads < 1 || threads > 64) return "camera.threads must be in [1, 64]";
  return "";
}

double StereoHeadConfig::fx() const {
  return 0.5 * width / std::tan(0.5 * hfov_deg * kDeg);
}

StereoHeadConfig StereoHeadConfig::scaledTo(int new_width, int new_height) const {
  StereoHeadConfig c = *this;
  c.width = new_width;
  c.height = new_height;
  return c;
}

StereoCameraModel stereoCameraModel(const StereoHeadConfig& head) {
  StereoCameraModel m;
  m.fx = m.fy = head.fx();
  m.cx = m.cx_right = head.cx();
  m.cy = head.cy();
  m.baseline = head.baseline;
  m.width = head.width;
  m.height = head.height;
  return m;
}

Eigen::Matrix3d linkToOpticalRotation() {
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d(0, -1, 0);  // optical x = right = -y of the body
  R.col(1) = Eigen::Vector3d(0, 0, -1);  // optical y = down
  R.col(2) = Eigen::Vector3d(1, 0, 0);   // optical z = forward
  return R;
}

Eigen::Isometry3d StereoHeadConfig::baseToCameraLink() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(mount_x, mount_y, mount_z);
  // A positive rotation about y tilts the x axis down.
  T.linear() = Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return T;
}

Eigen::Isometry3d StereoHeadConfig::baseToLeftOptical() const {
  Eigen::Isometry3d T = baseToCameraLink();
  T.linear() = T.linear() * linkToOpticalRotation();
  return T;
}

Eigen::Isometry3d basePose(double x, double y, double z, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

StereoRenderer::StereoRenderer(const Scene& scene, const StereoHeadConfig& config,
                               std::uint64_t seed)
    : scene_(scene), config_(config), seed_(seed) {
  std::string e = config_.validate();
  if (e.empty()) e = scene_.validate();
  if (!e.empty()) throw std::invalid_argument("StereoRenderer: " + e);
  scene_.lighting.direction.normalize();
  fx_ = config_.fx();
  tiles_x_ = (config_.width + kTile - 1) / kTile;
  tiles_y_ = (config_.height + kTile - 1) / kTile;
  for (View& v : views_)
    v.tiles.resize(static_cast<std::size_t>(tiles_x_) * tiles_y_);
  // Image noise from a table of unit Gaussian samples indexed by a per-pixel hash: the same
  // values whatever the thread count (Box-Muller on a fixed engine, portable across libraries).
  std::mt19937_64 rng(mix64(seed ^ 0x5eed));
  gauss_table_.resize(1 << 16);
  for (std::size_t i = 0; i < gauss_table_.size(); i += 2) {
    const double u1 = (static_cast<double>(rng() >> 11) + 1.0) * (1.0 / 9007199254740993.0);
    const double u2 = static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0);
    const double r = std::sqrt(-2.0 * std::log(u1));
    gauss_table_[i] = static_cast<float>(r * std::cos(2.0 * M_PI * u2));
    gauss_table_[i + 1] = static_cast<float>(r * std::sin(2.0 * M_PI * u2));
  }
}

void StereoRenderer::cullTiles(View* view) const {
  for (auto& t : view->tiles)
    t.clear();
  const Eigen::Matrix3d Rt = view->R.transpose();
  const double near = config_.near_clip;
  const double cx = config_.cx(), cy = config_.cy();
  std::vector<Eigen::Vector3d>& pts = view->pts;
  std::vector<Eigen::Vector3d>& hull = view->hull;
  for (std::size_t i = 0; i < scene_.primitives.size(); ++i) {
    const Primitive& p = scene_.primitives[i];
    hull.clear();
    if (p.shape == Primitive::Shape::kConvex) {
      hull.insert(hull.end(), p.vertices.begin(), p.vertices.end());
    } else {
      for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d s((c & 1) ? 1 : -1, (c & 2) ? 1 : -1, (c & 4) ? 1 : -1);
        hull.push_back(p.obb.center + p.obb.rotation * p.obb.half_size.cwiseProduct(s));
      }
    }
    pts.clear();
    for (const auto& w : hull)
      pts.push_back(Rt * (w - view->origin));
    // Bounds of the projection of the solid clipped at the near plane: projected vertices in
    // front plus the near-plane crossings of all vertex pairs (a superset of the edges).
    double umin = 1e30, umax = -1e30, vmin = 1e30, vmax = -1e30;
    bool any = false;
    auto addPoint = [&](const Eigen::Vector3d& q) {
      const double u = fx_ * q.x() / q.z() + cx, v = fx_ * q.y() / q.z() + cy;
      umin = std::min(umin, u);
      umax = std::max(umax, u);
      vmin = std::min(vmin, v);
      vmax = std::max(vmax, v);
      any = true;
    };
    for (std::size_t a = 0; a < pts.size(); ++a) {
      if (pts[a].z() >= near) addPoint(pts[a]);
      for (std::size_t b = a + 1; b < pts.size(); ++b) {
        const double za = pts[a].z() - near, zb = pts[b].z() - near;
        if ((za < 0.0) != (zb < 0.0)) addPoint(pts[a] + (za / (za - zb)) * (pts[b] - pts[a]));
      }
    }
    if (!any) continue;
    // Points just in front of the near plane project far away: clamp before converting to int.
    umin = std::max(umin, -1e6);
    vmin = std::max(vmin, -1e6);
    umax = std::min(umax, 1e6);
    vmax = std::min(vmax, 1e6);
    if (umax < -1.0 || vmax < -1.0 || umin > config_.width || vmin > config_.height) continue;
    const int tx0 = std::max(0, static_cast<int>(std::floor((umin - 1.0) / kTile)));
    const int tx1 = std::min(tiles_x_ - 1, static_cast<int>(std::floor((umax + 1.0) / kTile)));
    const int ty0 = std::max(0, static_cast<int>(std::floor((vmin - 1.0) / kTile)));
    const int ty1 = std::min(tiles_y_ - 1, static_cast<int>(std::floor((vmax + 1.0) / kTile)));
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx)
        view->tiles[static_cast<std::size_t>(ty) * tiles_x_ + tx].push_back(static_cast<int>(i));
  }
}

Eigen::Vector3f StereoRenderer::background(const Eigen::Vector3d& dir) const {
  const double e = dir.z() / dir.norm();
  if (e <= 0.0) return scene_.sky_horizon;
  const float a = static_cast<float>(std::min(1.0, std::sqrt(e)));
  return (1.0f - a) * scene_.sky_horizon + a * scene_.sky_zenith;
}

Eigen::Vector3f StereoRenderer::shade(const Ray& ray, const Hit& hit,
                                      double footprint_scale) const {
  const Primitive& prim = scene_.primitives[hit.primitive];
  const Eigen::Vector3d p = ray.origin + hit.t * ray.dir;
  Eigen::Vector3d n = hit.normal;
  const double dn = ray.dir.norm();
  double cos_inc = -n.dot(ray.dir) / dn;
  if (cos_inc < 0.0) {  // seen from inside: light the face we look at
    n = -n;
    cos_inc = -cos_inc;
  }
  const bool side = std::abs(n.z()) < 0.7;
  const Material& m =
      scene_.materials[(side && prim.side_material >= 0) ? prim.side_material : prim.material];
  double u, v;
  if (prim.shape == Primitive::Shape::kCylinder && hit.face == -1) {
    const Eigen::Vector3d o = p - prim.p0;
    const double s = o.dot(prim.axis);
    const Eigen::Vector3d r = o - s * prim.axis;
    u = s;
    v = prim.radius * std::atan2(r.dot(prim.obb.rotation.col(1)), r.dot(prim.obb.rotation.col(0)));
  } else if (!side) {
    u = p.x();
    v = p.y();
  } else {
    const double h = std::hypot(n.x(), n.y());
    u = (-n.y() * p.x() + n.x() * p.y()) / h;
    v = p.z();
  }
  // Pixel footprint on the surface: distance times pixel angle, widened on oblique surfaces
  // (geometric mean of the two footprint axes) so that textures are band-limited like a real
  // camera's pixel integration.
  const double fp = hit.t * dn * footprint_scale / std::sqrt(std::max(cos_inc, 0.05));
  const double t = evaluateTexture(m, u, v, fp);
  const double grain = m.effectiveGrain();
  const double g = grain > 0.0 ? grain * evaluateGrain(m, u, v, fp) : 0.0;
  Eigen::Vector3f albedo = m.colour * static_cast<float>(1.0 + m.contrast * t + g);
  albedo = albedo.cwiseMax(0.0f).cwiseMin(1.0f);
  const double lambert = std::max(0.0, -n.dot(scene_.lighting.direction));
  return albedo * static_cast<float>(scene_.lighting.ambient + scene_.lighting.diffuse * lambert);
}

float StereoRenderer::shadeRay(const Ray& ray, double t_min, Hit* hit_out) const {
  Hit hit;
  Eigen::Vector3f rad;
  if (scene_.intersect(ray, t_min, config_.max_depth * ray.dir.norm(), &hit)) {
    rad = shade(ray, hit, 1.0 / fx_);
  } else {
    rad = background(ray.dir);
  }
  if (hit_out) *hit_out = hit;
  const float lum = 0.299f * rad.x() + 0.587f * rad.y() + 0.114f * rad.z();
  return static_cast<float>(255.0 * config_.exposure) * lum;
}

void StereoRenderer::renderBand(int cam, int tile_row, std::uint64_t /*frame*/) {
  const View& view = views_[cam];
  const int W = config_.width, H = config_.height;
  const double cx = config_.cx(), cy = config_.cy();
  const double inv_f = 1.0 / fx_;
  const double near = config_.near_clip, far = config_.max_depth;
  const bool colour = config_.colour;
  const float scale = static_cast<float>(255.0 * config_.exposure) *
                      static_cast<float>(cam == 1 ? config_.right_gain : 1.0);
  const bool aux = want_aux_ && cam == 0;
  const int y0 = tile_row * kTile, y1 = std::min(H, y0 + kTile);
  Ray ray;
  ray.origin = view.origin;
  for (int y = y0; y < y1; ++y) {
    float* out = depth_only_ ? nullptr : radiance_[cam].ptr<float>(y);
    float* dep = aux ? depth_.ptr<float>(y) : nullptr;
    int* idp = aux ? ids_.ptr<int>(y) : nullptr;
    const Eigen::Vector3d row_dir = view.R.col(1) * ((y - cy) * inv_f) + view.R.col(2);
    for (int x = 0; x < W; ++x) {
      ray.dir = row_dir + view.R.col(0) * ((x - cx) * inv_f);  // optical z component = 1: t = Z
      const std::vector<int>& list =
          view.tiles[static_cast<std::size_t>(y / kTile) * tiles_x_ + x / kTile];
      Hit hit;
      hit.t = far;
      for (int id : list) {
        double tin, tout;
        int face;
        if (!scene_.primitives[id].interval(ray, &tin, &tout, &face)) continue;
        if (tin > near && tin < hit.t) {
          hit.t = tin;
          hit.primitive = id;
          hit.face = face;
        }
      }
      if (aux) {
        dep[x] =
            hit.primitive >= 0 ? static_cast<float>(hit.t) : std::numeric_limits<float>::infinity();
        idp[x] = hit.primitive;
      }
      if (depth_only_) continue;  // renderDepth(): no shading
      Eigen::Vector3f rad;
      if (hit.primitive >= 0) {
        hit.normal =
            scene_.primitives[hit.primitive].normalAt(hit.face, ray.origin + hit.t * ray.dir);
        rad = shade(ray, hit, inv_f);
      } else {
        rad = background(ray.dir);
      }
      if (colour) {
        out[3 * x + 0] = scale * rad.z();  // BGR
        out[3 * x + 1] = scale * rad.y();
        out[3 * x + 2] = scale * rad.x();
      } else {
        out[x] = scale * (0.299f * rad.x() + 0.587f * rad.y() + 0.114f * rad.z());
      }
    }
  }
}

bool StereoRenderer::render(const Eigen::Isometry3d& T_world_left, std::uint64_t frame,
                            cv::Mat* left, cv::Mat* right, cv::Mat* left_depth, cv::Mat* left_ids) {
  if (!T_world_left.matrix().allFinite()) return false;
  const int W = config_.width, H = config_.height;
  const int ftype = config_.colour ? CV_32FC3 : CV_32FC1;
  const int otype = config_.colour ? CV_8UC3 : CV_8UC1;
  views_[0].R = T_world_left.linear();
  views_[0].origin = T_world_left.translation();
  views_[1].R = views_[0].R;
  views_[1].origin = views_[0].origin + views_[0].R.col(0) * config_.baseline;
  want_aux_ = left_depth != nullptr || left_ids != nullptr;
  for (int c = 0; c < 2; ++c) {
    radiance_[c].create(H, W, ftype);
    cullTiles(&views_[c]);
  }
  if (want_aux_) {
    depth_.create(H, W, CV_32F);
    ids_.create(H, W, CV_32S);
  }
  parallelFor(2 * tiles_y_, config_.threads,
              [&](int job) { renderBand(job / tiles_y_, job % tiles_y_, frame); });

  cv::Mat* outs[2] = {left, right};
  parallelFor(2, config_.threads, [&](int c) {
    const cv::Mat* src = &radiance_[c];
    if (config_.blur_sigma > 0.0) {
      cv::GaussianBlur(radiance_[c], blurred_[c], cv::Size(0, 0), config_.blur_sigma, 0.0,
                       cv::BORDER_REPLICATE);
      src = &blurred_[c];
    }
    if (!outs[c]) return;
    outs[c]->create(H, W, otype);
    const int ch = config_.colour ? 3 : 1;
    const float sigma = static_cast<float>(config_.noise_sigma);
    const std::uint64_t base = mix64(seed_ ^ mix64(frame * 2 + c + 1));
    for (int y = 0; y < H; ++y) {
      const float* s = src->ptr<float>(y);
      std::uint8_t* d = outs[c]->ptr<std::uint8_t>(y);
      for (int k = 0; k < W * ch; ++k) {
        float val = s[k];
        if (sigma > 0.0f) {
          const std::uint64_t h = mix64(base + static_cast<std::uint64_t>(y) * W * ch + k);
          val += sigma * gauss_table_[h & 0xFFFF];
        }
        d[k] = static_cast<std::uint8_t>(std::min(255.0f, std::max(0.0f, std::round(val))));
      }
    }
  });
  if (left_depth) depth_.copyTo(*left_depth);
  if (left_ids) ids_.copyTo(*left_ids);
  return true;
}

bool StereoRenderer::renderDepth(const Eigen::Isometry3d& T_world_left, cv::Mat* left_depth,
                                 cv::Mat* left_ids) {
  if (!T_world_left.matrix().allFinite()) return false;
  views_[0].R = T_world_left.linear();
  views_[0].origin = T_world_left.translation();
  cullTiles(&views_[0]);
  want_aux_ = true;
  depth_only_ = true;
  depth_.create(config_.height, config_.width, CV_32F);
  ids_.create(config_.height, config_.width, CV_32S);
  parallelFor(tiles_y_, config_.threads, [&](int job) { renderBand(0, job, 0); });
  depth_only_ = false;
  if (left_depth) depth_.copyTo(*left_depth);
  if (left_ids) ids_.copyTo(*left_ids);
  return true;
}

}  // namespace dataset
}  // namespace stereo_safety_map
