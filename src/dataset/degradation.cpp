#include "stereo_safety_map/dataset/degradation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

namespace {

constexpr double kDeg = M_PI / 180.0;

double wrapAngle(double a) {
  return std::remainder(a, 2.0 * M_PI);
}

// The fields of DegradationConfig by name, for parseDegradation and describe.
struct Field {
  const char* name;
  double DegradationConfig::*num;
  int DegradationConfig::*integer;
  bool DegradationConfig::*flag;
};

const std::vector<Field>& fields() {
  using D = DegradationConfig;
  static const std::vector<Field> kFields = {
      {"chassis_jitter_deg", &D::chassis_jitter_deg, nullptr, nullptr},
      {"chassis_pitch_offset_deg", &D::chassis_pitch_offset_deg, nullptr, nullptr},
      {"chassis_roll_offset_deg", &D::chassis_roll_offset_deg, nullptr, nullptr},
      {"heading_walk_deg", &D::heading_walk_deg, nullptr, nullptr},
      {"distance_scale_error", &D::distance_scale_error, nullptr, nullptr},
      {"noise_sigma", &D::noise_sigma, nullptr, nullptr},
      {"right_gain_mismatch", &D::right_gain_mismatch, nullptr, nullptr},
      {"vertical_misrect_px", &D::vertical_misrect_px, nullptr, nullptr},
      {"exposure_time_s", &D::exposure_time_s, nullptr, nullptr},
      {"vignetting", &D::vignetting, nullptr, nullptr},
      {"exposure_jitter", &D::exposure_jitter, nullptr, nullptr},
      {"exposure_step", &D::exposure_step, nullptr, nullptr},
      {"exposure_step_period", nullptr, &D::exposure_step_period, nullptr},
      {"no_grain", nullptr, nullptr, &D::no_grain},
  };
  return kFields;
}

std::string trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  const std::size_t b = s.find_last_not_of(" \t");
  return s.substr(a, b - a + 1);
}

}  // namespace

// ---- config ----

DegradationConfig DegradationConfig::none() {
  DegradationConfig d;
  d.chassis_jitter_deg = 0.0;
  d.chassis_pitch_offset_deg = 0.0;
  d.chassis_roll_offset_deg = 0.0;
  d.heading_walk_deg = 0.0;
  d.distance_scale_error = 0.0;
  d.noise_sigma = -1.0;
  d.right_gain_mismatch = 0.0;
  d.vertical_misrect_px = 0.0;
  d.exposure_time_s = 0.0;
  d.vignetting = 0.0;
  d.exposure_jitter = 0.0;
  d.exposure_step = 0.0;
  d.exposure_step_period = 0;
  d.no_grain = false;
  return d;
}

DegradationConfig DegradationConfig::defaults() {
  return DegradationConfig();
}

DegradationConfig DegradationConfig::strong() {
  DegradationConfig d;
  d.chassis_jitter_deg = 1.5;
  d.chassis_pitch_offset_deg = 1.5;
  d.chassis_roll_offset_deg = 1.0;
  d.heading_walk_deg = 0.2;
  d.distance_scale_error = 0.05;
  d.noise_sigma = 8.0;
  d.right_gain_mismatch = 0.10;
  d.vertical_misrect_px = 0.5;
  d.exposure_time_s = 0.020;
  d.vignetting = 0.35;
  d.exposure_jitter = 0.10;
  d.exposure_step = 0.2;
  d.exposure_step_period = 40;
  d.no_grain = true;
  return d;
}

bool DegradationConfig::isNone() const {
  return chassis_jitter_deg == 0.0 && chassis_pitch_offset_deg == 0.0 &&
         chassis_roll_offset_deg == 0.0 && heading_walk_deg == 0.0 && distance_scale_error == 0.0 &&
         noise_sigma < 0.0 && right_gain_mismatch == 0.0 && vertical_misrect_px == 0.0 &&
         exposure_time_s == 0.0 && vignetting == 0.0 && exposure_jitter == 0.0 &&
         (exposure_step == 0.0 || exposure_step_period == 0) && !no_grain;
}

std::string DegradationConfig::validate() const {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!in(chassis_jitter_deg, 0.0, 5.0)) return "degradation.chassis_jitter_deg must be in [0, 5]";
  if (!in(chassis_pitch_offset_deg, -5.0, 5.0))
    return "degradation.chassis_pitch_offset_deg must be in [-5, 5]";
  if (!in(chassis_roll_offset_deg, -5.0, 5.0))
    return "degradation.chassis_roll_offset_deg must be in [-5, 5]";
  if (!in(heading_walk_deg, 0.0, 2.0)) return "degradation.heading_walk_deg must be in [0, 2]";
  if (!in(distance_scale_error, -0.5, 0.5))
    return "degradation.distance_scale_error must be in [-0.5, 0.5]";
  if (!(noise_sigma == -1.0 || in(noise_sigma, 0.0, 50.0)))
    return "degradation.noise_sigma must be -1 (keep the camera's) or in [0, 50]";
  if (!in(right_gain_mismatch, -0.3, 0.3))
    return "degradation.right_gain_mismatch must be in [-0.3, 0.3]";
  if (!in(vertical_misrect_px, -3.0, 3.0))
    return "degradation.vertical_misrect_px must be in [-3, 3] [px]";
  if (!in(exposure_time_s, 0.0, 0.1)) return "degradation.exposure_time_s must be in [0, 0.1] [s]";
  if (!in(vignetting, 0.0, 0.9)) return "degradation.vignetting must be in [0, 0.9]";
  if (!in(exposure_jitter, 0.0, 0.5)) return "degradation.exposure_jitter must be in [0, 0.5]";
  if (!in(exposure_step, -0.9, 2.0)) return "degradation.exposure_step must be in [-0.9, 2]";
  if (exposure_step_period < 0 || exposure_step_period > 100000)
    return "degradation.exposure_step_period must be in [0, 100000] [frames]";
  return "";
}

std::string DegradationConfig::describe() const {
  std::ostringstream s;
  bool first = true;
  for (const Field& f : fields()) {
    s << (first ? "" : ",") << f.name << "=";
    first = false;
    if (f.num) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.6g", this->*f.num);
      s << buf;
    } else if (f.integer) {
      s << this->*f.integer;
    } else {
      s << (this->*f.flag ? "true" : "false");
    }
  }
  return s.str();
}

std::string parseDegradation(const std::string& spec, DegradationConfig* out) {
  std::vector<std::string> tokens;
  std::stringstream ss(spec);
  std::string tok;
  while (std::getline(ss, tok, ','))
    tokens.push_back(trim(tok));
  DegradationConfig d = DegradationConfig::defaults();
  std::size_t i = 0;
  if (!tokens.empty() && tokens[0].find('=') == std::string::npos) {
    if (tokens[0] == "none") {
      d = DegradationConfig::none();
    } else if (tokens[0] == "default" || tokens[0] == "defaults") {
      d = DegradationConfig::defaults();
    } else if (tokens[0] == "strong") {
      d = DegradationConfig::strong();
    } else {
      return "degradation: unknown preset '" + tokens[0] + "' (none, default, strong)";
    }
    i = 1;
  }
  for (; i < tokens.size(); ++i) {
    const std::string& t = tokens[i];
    const std::size_t eq = t.find('=');
    if (eq == std::string::npos) return "degradation: expected key=value, not '" + t + "'";
    const std::string key = trim(t.substr(0, eq)), value = trim(t.substr(eq + 1));
    const Field* field = nullptr;
    for (const Field& f : fields())
      if (key == f.name) field = &f;
    if (!field) return "degradation: unknown key '" + key + "'";
    if (field->flag) {
      if (value == "true" || value == "1") {
        d.*(field->flag) = true;
      } else if (value == "false" || value == "0") {
        d.*(field->flag) = false;
      } else {
        return "degradation." + key + ": expected true or false, not '" + value + "'";
      }
      continue;
    }
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || end != value.c_str() + value.size() || !std::isfinite(v))
      return "degradation." + key + ": expected a number, not '" + value + "'";
    if (field->integer) {
      if (v != std::floor(v) || std::abs(v) > 1e9)
        return "degradation." + key + ": expected an integer, not '" + value + "'";
      d.*(field->integer) = static_cast<int>(v);
    } else {
      d.*(field->num) = v;
    }
  }
  const std::string e = d.validate();
  if (!e.empty()) return e;
  *out = d;
  return "";
}

void applyToRender(const DegradationConfig& d, StereoHeadConfig* camera, Scene* scene) {
  if (camera) {
    if (d.noise_sigma >= 0.0) camera->noise_sigma = d.noise_sigma;
    if (d.right_gain_mismatch != 0.0) camera->right_gain *= 1.0 + d.right_gain_mismatch;
  }
  if (scene && d.no_grain)
    for (Material& m : scene->materials)
      m.grain = 0.0;
}

// ---- odometry ----

OdometryErrorModel::OdometryErrorModel(const DegradationConfig& config, std::uint64_t seed)
    : config_(config), seed_(seed), rng_(seed ^ 0x0D0E7E11ull) {}

void OdometryErrorModel::reset() {
  rng_ = PortableRng(seed_ ^ 0x0D0E7E11ull);
  started_ = false;
  rep_x_ = rep_y_ = rep_yaw_ = 0.0;
  jitter_pitch_deg_ = jitter_roll_deg_ = 0.0;
}

OdometryErrorModel::FramePoses OdometryErrorModel::next(const RobotPose& truth,
                                                        const StereoHeadConfig& head) {
  const bool moved = !started_ || !truth.stationary;
  // Chassis bobbing: new on a moving frame, held while standing still.
  if (config_.chassis_jitter_deg > 0.0 && moved) {
    jitter_pitch_deg_ = config_.chassis_jitter_deg * rng_.normal();
    jitter_roll_deg_ = config_.chassis_jitter_deg * rng_.normal();
  }
  // Odometry: integrate the true increments with the scale error and the heading walk.
  const bool drift = config_.heading_walk_deg > 0.0 || config_.distance_scale_error != 0.0;
  if (!started_) {
    rep_x_ = truth.x;
    rep_y_ = truth.y;
    rep_yaw_ = truth.yaw;
  } else if (drift && !truth.stationary) {
    const double c = std::cos(last_.yaw), s = std::sin(last_.yaw);
    const double dx = truth.x - last_.x, dy = truth.y - last_.y;
    const double bx = c * dx + s * dy, by = -s * dx + c * dy;  // in the previous true base frame
    const double k = 1.0 + config_.distance_scale_error;
    const double rc = std::cos(rep_yaw_), rs = std::sin(rep_yaw_);
    rep_x_ += k * (rc * bx - rs * by);
    rep_y_ += k * (rs * bx + rc * by);
    rep_yaw_ = wrapAngle(
        rep_yaw_ + wrapAngle(truth.yaw - last_.yaw) +
        (config_.heading_walk_deg > 0.0 ? config_.heading_walk_deg * kDeg * rng_.normal() : 0.0));
  }
  started_ = true;
  last_ = truth;

  FramePoses f;
  const Eigen::Isometry3d T_base_opt = head.baseToLeftOptical();
  f.true_base = basePose(truth.x, truth.y, truth.z, truth.yaw);
  f.chassis_pitch_deg = config_.chassis_pitch_offset_deg + jitter_pitch_deg_;
  f.chassis_roll_deg = config_.chassis_roll_offset_deg + jitter_roll_deg_;
  if (f.chassis_pitch_deg == 0.0 && f.chassis_roll_deg == 0.0) {
    f.true_left_optical = f.true_base * T_base_opt;
  } else {
    // Tilt about base_link (on the ground between the drive wheels): pitch about y (positive =
    // the front dips), then roll about x (positive = the left side rises).
    Eigen::Isometry3d tilt = Eigen::Isometry3d::Identity();
    tilt.linear() = (Eigen::AngleAxisd(f.chassis_pitch_deg * kDeg, Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(f.chassis_roll_deg * kDeg, Eigen::Vector3d::UnitX()))
                        .toRotationMatrix();
    f.true_left_optical = f.true_base * tilt * T_base_opt;
  }
  if (drift) {
    f.reported_base = basePose(rep_x_, rep_y_, truth.z, rep_yaw_);
    f.reported_left_optical = f.reported_base * T_base_opt;
  } else {
    f.reported_base = f.true_base;
    f.reported_left_optical = f.true_base * T_base_opt;
  }
  return f;
}

// ---- images ----

ImageDegrader::ImageDegrader(const DegradationConfig& config, std::uint64_t seed)
    : config_(config), seed_(seed) {
  // Unit Gaussians indexed by a per-pixel hash (as the renderer's noise): fast, and the same
  // whatever order the frames come in.
  PortableRng rng(seed ^ 0x7015Eull);
  gauss_.resize(1 << 16);
  for (float& g : gauss_)
    g = static_cast<float>(rng.normal());
}

double ImageDegrader::exposureGain(std::uint64_t frame) const {
  double g = 1.0;
  if (config_.exposure_jitter > 0.0) {
    PortableRng r(mixSeed(seed_ ^ 0xE7905Eull) ^ mixSeed(frame));
    g = std::max(0.05, 1.0 + config_.exposure_jitter * r.normal());
  }
  if (config_.exposure_step_period > 0 && config_.exposure_step != 0.0 &&
      (frame / static_cast<std::uint64_t>(config_.exposure_step_period)) % 2 == 1)
    g *= 1.0 + config_.exposure_step;
  return g;
}

Eigen::Vector2d ImageDegrader::blurAt(const RobotPose& motion, const StereoHeadConfig& head,
                                      int row) const {
  const double T = config_.exposure_time_s;
  if (!(T > 0.0)) return Eigen::Vector2d::Zero();
  const double fx = head.fx();
  const double lx = fx * std::abs(motion.omega) * T;
  double ly = 0.0;
  const double tr = (row - head.cy()) / fx;
  const double a = head.pitch_deg * kDeg + std::atan(tr);  // depression below the horizon
  if (a > 0.0 && head.mount_z > 0.0) {
    const double s = std::sin(a);
    ly = fx * std::abs(motion.v) * T * s * s / head.mount_z * (1.0 + tr * tr);
  }
  return Eigen::Vector2d(std::min(lx, 100.0), std::min(ly, 100.0));
}

void ImageDegrader::apply(std::uint64_t frame, const RobotPose& motion,
                          const StereoHeadConfig& head, cv::Mat* left, cv::Mat* right) {
  const DegradationConfig& c = config_;
  const double gain = exposureGain(frame);
  const bool blur = c.exposure_time_s > 0.0 && (motion.v != 0.0 || motion.omega != 0.0);
  if (gain == 1.0 && c.vignetting == 0.0 && !blur && c.vertical_misrect_px == 0.0) return;
  const double sigma = std::max(0.0, head.noise_sigma);
  cv::Mat* imgs[2] = {left, right};
  for (int cam = 0; cam < 2; ++cam) {
    cv::Mat* img = imgs[cam];
    if (!img || img->empty()) continue;
    const int H = img->rows, W = img->cols, ch = img->channels();
    img->convertTo(work_, CV_32F);
    // Exposure and vignetting.
    if (gain != 1.0 || c.vignetting > 0.0) {
      const double cx = 0.5 * (W - 1), cy = 0.5 * (H - 1);
      const double r2c = cx * cx + cy * cy;
      for (int y = 0; y < H; ++y) {
        float* p = work_.ptr<float>(y);
        for (int x = 0; x < W; ++x) {
          const double r2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
          const float g = static_cast<float>(gain * (1.0 - c.vignetting * r2 / r2c));
          for (int k = 0; k < ch; ++k)
            p[x * ch + k] *= g;
        }
      }
    }
    // Share of the rendered noise variance left after the linear filters, per row.
    std::vector<double> rho(H, 1.0);
    // Motion blur: a box along the row's blur vector, centred on the pixel.
    if (blur) {
      struct Tap {
        const float* r0;
        const float* r1;
        float fy;
        int ix;
        float fx;
      };
      std::vector<Tap> taps;
      out_.create(H, W, work_.type());
      for (int y = 0; y < H; ++y) {
        const Eigen::Vector2d d = blurAt(motion, head, y);
        const double L = d.norm();
        float* o = out_.ptr<float>(y);
        if (L < 0.05) {
          std::copy(work_.ptr<float>(y), work_.ptr<float>(y) + W * ch, o);
          continue;
        }
        const int n = static_cast<int>(std::ceil(L)) + 1;
        rho[y] = 1.0 / (1.0 + L);  // n samples <= 1 px apart: exact for whole-pixel kernels
        // The taps of this row: rows, vertical weight, horizontal offset and weight (bilinear).
        taps.resize(n);
        for (int i = 0; i < n; ++i) {
          const double t = static_cast<double>(i) / (n - 1) - 0.5;
          const double yy = std::min(std::max(y + t * d.y(), 0.0), H - 1.0);
          const int y0 = static_cast<int>(yy);
          const double ox = t * d.x();
          Tap& tp = taps[i];
          tp.r0 = work_.ptr<float>(y0);
          tp.r1 = work_.ptr<float>(std::min(y0 + 1, H - 1));
          tp.fy = static_cast<float>(yy - y0);
          tp.ix = static_cast<int>(std::floor(ox));
          tp.fx = static_cast<float>(ox - tp.ix);
        }
        const float inv = 1.0f / n;
        for (int x = 0; x < W; ++x) {
          for (int k = 0; k < ch; ++k) {
            float acc = 0.0f;
            for (const Tap& tp : taps) {
              const int xa = std::min(std::max(x + tp.ix, 0), W - 1) * ch + k;
              const int xb = std::min(std::max(x + tp.ix + 1, 0), W - 1) * ch + k;
              const float a = tp.r0[xa] + tp.fx * (tp.r0[xb] - tp.r0[xa]);
              const float b = tp.r1[xa] + tp.fx * (tp.r1[xb] - tp.r1[xa]);
              acc += a + tp.fy * (b - a);
            }
            o[x * ch + k] = acc * inv;
          }
        }
      }
      std::swap(work_, out_);
    }
    // Vertical misrectification of the right image: content moved down by s px.
    if (cam == 1 && c.vertical_misrect_px != 0.0) {
      const double s = c.vertical_misrect_px;
      const double fl = std::floor(s);
      const float f = static_cast<float>(s - fl);
      const int i0 = static_cast<int>(fl);
      out_.create(H, W, work_.type());
      for (int y = 0; y < H; ++y) {
        const int ya = std::min(std::max(y - i0, 0), H - 1);      // weight 1 - f
        const int yb = std::min(std::max(y - i0 - 1, 0), H - 1);  // weight f
        const float* a = work_.ptr<float>(ya);
        const float* b = work_.ptr<float>(yb);
        float* o = out_.ptr<float>(y);
        for (int k = 0; k < W * ch; ++k)
          o[k] = (1.0f - f) * a[k] + f * b[k];
      }
      std::swap(work_, out_);
      const double fr = s - fl;
      for (double& r : rho)
        r *= (1.0 - fr) * (1.0 - fr) + fr * fr;
    }
    // Noise top-up and back to 8 bits.
    const std::uint64_t base = mixSeed(seed_ ^ mixSeed(frame * 2 + cam + 1));
    for (int y = 0; y < H; ++y) {
      const float* p = work_.ptr<float>(y);
      std::uint8_t* d = img->ptr<std::uint8_t>(y);
      const float add = static_cast<float>(sigma * std::sqrt(std::max(0.0, 1.0 - rho[y])));
      const std::uint64_t row = base + static_cast<std::uint64_t>(y) * W * ch;
      for (int k = 0; k < W * ch; ++k) {
        float v = p[k];
        if (add > 1e-3f) v += add * gauss_[mixSeed(row + k) & 0xFFFF];
        d[k] = static_cast<std::uint8_t>(std::min(255.0f, std::max(0.0f, std::round(v))));
      }
    }
  }
}

}  // namespace dataset
}  // namespace stereo_safety_map
