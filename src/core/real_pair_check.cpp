#include "stereo_safety_map/core/real_pair_check.h"

#include <Eigen/Eigenvalues>
#include <opencv2/core/persistence.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

namespace stereo_safety_map {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kDegToRad = M_PI / 180.0;
constexpr int kMinInliers = 50;
constexpr std::size_t kMaxRansacPoints = 20000;

std::string outOfRange(const char* name, double v, const char* range) {
  std::ostringstream os;
  os << name << " = " << v << " must be in " << range;
  return os.str();
}

// n . p + d = 0 with the camera (origin) on the positive side.
void orientTowardsCamera(Eigen::Vector3d* n, double* d) {
  if (*d < 0.0) {
    *n = -*n;
    *d = -*d;
  }
}

// Least-squares plane through points (centroid + smallest principal axis).
bool fitPlane(const std::vector<Eigen::Vector3d>& pts, Eigen::Vector3d* n, double* d) {
  if (pts.size() < 3) return false;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts)
    c += p;
  c /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts)
    cov += (p - c) * (p - c).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  if (es.info() != Eigen::Success) return false;
  *n = es.eigenvectors().col(0).normalized();
  *d = -n->dot(c);
  return n->allFinite() && std::isfinite(*d);
}

}  // namespace

std::string RealPairCheckConfig::validate() const {
  std::string err = processor.validate();
  if (!err.empty()) return "processor." + err;
  if (!(seed_radius > 0.0 && seed_radius <= 100.0))
    return outOfRange("seed_radius", seed_radius, "(0, 100] m");
  if (ransac_iterations < 1 || ransac_iterations > 100000)
    return outOfRange("ransac_iterations", ransac_iterations, "[1, 100000]");
  if (!(ransac_threshold > 0.0 && ransac_threshold <= 1.0))
    return outOfRange("ransac_threshold", ransac_threshold, "(0, 1] m");
  if (!(ransac_max_range > 0.0 && ransac_max_range <= 100.0))
    return outOfRange("ransac_max_range", ransac_max_range, "(0, 100] m");
  if (!(max_tilt_deg > 0.0 && max_tilt_deg <= 90.0))
    return outOfRange("max_tilt_deg", max_tilt_deg, "(0, 90] deg");
  if (refinements < 0 || refinements > 10) return outOfRange("refinements", refinements, "[0, 10]");
  return "";
}

GroundPlaneEstimate cameraPoseFromPlane(const Eigen::Vector3d& n_camera, double d) {
  GroundPlaneEstimate e;
  const double norm = n_camera.norm();
  if (!(norm > 0.0) || !std::isfinite(norm) || !std::isfinite(d)) return e;
  Eigen::Vector3d n = n_camera / norm;
  d /= norm;
  orientTowardsCamera(&n, &d);
  e.found = true;
  e.camera_height = d;
  // Optical axis is +z, image x is +x of the optical frame; n points up, towards the camera.
  e.pitch_deg = std::asin(std::clamp(-n.z(), -1.0, 1.0)) * kRadToDeg;
  e.roll_deg = std::asin(std::clamp(n.x(), -1.0, 1.0)) * kRadToDeg;
  return e;
}

GroundPlaneEstimate dominantGroundPlane(const SafetyMap& map,
                                        const Eigen::Isometry3d& T_fixed_camera) {
  int best = -1, best_any = -1;
  for (std::size_t k = 0; k < map.segments.size(); ++k) {
    const SegmentInfo& s = map.segments[k];
    // A plane with no points is not a measurement: SafetyMapper gives a robot segment that holds
    // the footprint but has no plane of its own the base's level plane (issue 15, "the robot
    // stands on ground"). Levelling on it would return the pose guess it was made from.
    if (!s.plane.valid || s.plane.from_base) continue;
    const int n = static_cast<int>(s.cells.size());
    if (best_any < 0 || n > static_cast<int>(map.segments[best_any].cells.size()))
      best_any = static_cast<int>(k);
    if (isSafe(s.label) && (best < 0 || n > static_cast<int>(map.segments[best].cells.size())))
      best = static_cast<int>(k);
  }
  if (best < 0) best = best_any;
  GroundPlaneEstimate e;
  if (best < 0) return e;
  const SegmentInfo& s = map.segments[best];
  const double norm = std::sqrt(s.plane.a * s.plane.a + s.plane.b * s.plane.b + 1.0);
  const Eigen::Vector3d n_f = Eigen::Vector3d(-s.plane.a, -s.plane.b, 1.0) / norm;
  const double d_f = -s.plane.c / norm;
  const Eigen::Matrix3d R = T_fixed_camera.linear();
  const Eigen::Vector3d n_c = R.transpose() * n_f;
  const double d_c = n_f.dot(T_fixed_camera.translation()) + d_f;
  e = cameraPoseFromPlane(n_c, d_c);
  e.slope_deg = std::acos(std::clamp(n_f.z(), -1.0, 1.0)) * kRadToDeg;
  e.label = s.label;
  e.segment = best;
  e.cells = static_cast<int>(s.cells.size());
  return e;
}

bool fitGroundPlaneRansac(const std::vector<Eigen::Vector3f>& points_camera,
                          const RealPairCheckConfig& config, Eigen::Vector3d* n_out,
                          double* d_out) {
  if (n_out == nullptr || d_out == nullptr) return false;
  // Candidates: finite points below the optical centre (y down) within range, evenly thinned.
  std::vector<Eigen::Vector3d> cand;
  std::size_t eligible = 0;
  auto usable = [&](const Eigen::Vector3f& p) {
    return p.allFinite() && p.y() > 0.0f && p.z() > 0.0f && p.norm() < config.ransac_max_range;
  };
  for (const auto& p : points_camera)
    eligible += usable(p) ? 1 : 0;
  if (eligible < static_cast<std::size_t>(kMinInliers)) return false;
  const std::size_t stride = std::max<std::size_t>(1, eligible / kMaxRansacPoints);
  std::size_t i = 0;
  for (const auto& p : points_camera) {
    if (!usable(p)) continue;
    if (i++ % stride == 0) cand.push_back(p.cast<double>());
  }

  const Eigen::Vector3d up(0.0, -1.0, 0.0);
  const double min_cos = std::cos(config.max_tilt_deg * kDegToRad);
  std::mt19937 rng(config.seed);
  std::uniform_int_distribution<std::size_t> pick(0, cand.size() - 1);
  auto countInliers = [&](const Eigen::Vector3d& n, double d) {
    int c = 0;
    for (const auto& p : cand)
      c += std::abs(n.dot(p) + d) < config.ransac_threshold ? 1 : 0;
    return c;
  };
  int best_count = 0;
  Eigen::Vector3d best_n = Eigen::Vector3d::Zero();
  double best_d = 0.0;
  for (int it = 0; it < config.ransac_iterations; ++it) {
    const Eigen::Vector3d& a = cand[pick(rng)];
    const Eigen::Vector3d& b = cand[pick(rng)];
    const Eigen::Vector3d& c = cand[pick(rng)];
    Eigen::Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    if (!(len > 1e-9)) continue;
    n /= len;
    if (n.dot(up) < 0.0) n = -n;
    if (n.dot(up) < min_cos) continue;
    const double d = -n.dot(a);
    if (d <= 0.0) continue;  // the camera must be above the plane
    const int count = countInliers(n, d);
    if (count > best_count) {
      best_count = count;
      best_n = n;
      best_d = d;
    }
  }
  if (best_count < kMinInliers) return false;
  // Least-squares refits on the inliers.
  std::vector<Eigen::Vector3d> inliers;
  for (int round = 0; round < 3; ++round) {
    inliers.clear();
    for (const auto& p : cand)
      if (std::abs(best_n.dot(p) + best_d) < config.ransac_threshold) inliers.push_back(p);
    Eigen::Vector3d n;
    double d;
    if (static_cast<int>(inliers.size()) < kMinInliers || !fitPlane(inliers, &n, &d)) break;
    if (n.dot(up) < 0.0) {
      n = -n;
      d = -d;
    }
    best_n = n;
    best_d = d;
  }
  if (!(best_d > 0.0)) return false;
  *n_out = best_n;
  *d_out = best_d;
  return true;
}

Eigen::Isometry3d levelledCameraPose(const Eigen::Vector3d& n_camera, double d) {
  Eigen::Vector3d n = n_camera.normalized();
  d /= n_camera.norm();
  orientTowardsCamera(&n, &d);
  Eigen::Vector3d x = Eigen::Vector3d::UnitZ() - n.z() * n;  // optical axis in the plane
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX() - n.x() * n;
  x.normalize();
  const Eigen::Vector3d y = n.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().row(0) = x.transpose();
  T.linear().row(1) = y.transpose();
  T.linear().row(2) = n.transpose();
  T.translation() = Eigen::Vector3d(0.0, 0.0, d);
  return T;
}

bool checkRealPair(const cv::Mat& left, const cv::Mat& right, const StereoCameraModel& camera,
                   const RealPairCheckConfig& config, RealPairResult* result) {
  if (result == nullptr) return false;
  RealPairResult& r = *result;
  r = RealPairResult();
  const std::string cfg_err = config.validate();
  if (!cfg_err.empty()) {
    r.error = "invalid configuration: " + cfg_err;
    return false;
  }
  const std::string cam_err = camera.validate();
  if (!cam_err.empty()) {
    r.error = "bad camera model: " + cam_err;
    return false;
  }
  if (left.empty() || left.cols != camera.width || left.rows != camera.height) {
    r.error = "left image does not have the camera model's size";
    return false;
  }
  StereoFrameProcessorConfig pc = config.processor;
  pc.mapper = singleFrameMapperConfig(pc.mapper, config.seed_radius);
  StereoFrameProcessor processor(pc);

  cv::Mat disparity;
  std::string err;
  // As StereoFrameProcessor::processImages does: coarse_fill_max_depth needs f B.
  processor.disparityPipeline().setFocalBaseline(camera.fx * camera.baseline);
  if (!processor.disparityPipeline().compute(left, right, &disparity, nullptr, &err)) {
    r.error = "disparity: " + err;
    return false;
  }
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, camera, pc.mapper.grid.min_range, pc.mapper.grid.max_range,
                     pc.disparity_step, &points);
  r.points = points.size();

  Eigen::Vector3d n;
  double d;
  if (!fitGroundPlaneRansac(points, config, &n, &d)) {
    r.error = "no ground plane in the pair's points";
    return false;
  }
  r.bootstrap = cameraPoseFromPlane(n, d);
  r.T_fixed_camera = levelledCameraPose(n, d);

  for (int pass = 0; pass <= config.refinements; ++pass) {
    processor.reset();
    const Eigen::Vector3d base(r.T_fixed_camera.translation().x(),
                               r.T_fixed_camera.translation().y(), 0.0);
    StereoFrameResult fr;
    if (!processor.processDisparity(disparity, camera, r.T_fixed_camera.cast<float>(),
                                    base.cast<float>(), StereoFrameProcessor::kNoStamp, &fr,
                                    &err)) {
      r.error = "mapper: " + err;
      return false;
    }
    r.map_plane = dominantGroundPlane(processor.mapper().safetyMap(), r.T_fixed_camera);
    if (!r.map_plane.found) {
      r.error = "the map has no ground segment with a plane";
      return false;
    }
    if (pass == config.refinements) break;
    // Re-level on the map's plane, expressed in the camera frame.
    const SegmentInfo& s = processor.mapper().safetyMap().segments[r.map_plane.segment];
    const double norm = std::sqrt(s.plane.a * s.plane.a + s.plane.b * s.plane.b + 1.0);
    const Eigen::Vector3d n_f = Eigen::Vector3d(-s.plane.a, -s.plane.b, 1.0) / norm;
    const double d_f = -s.plane.c / norm;
    const Eigen::Vector3d n_c = r.T_fixed_camera.linear().transpose() * n_f;
    const double d_c = n_f.dot(r.T_fixed_camera.translation()) + d_f;
    r.T_fixed_camera = levelledCameraPose(n_c, d_c);
  }
  r.map = processor.mapper().safetyMap();
  r.disparity = disparity;
  for (SafetyLabel l : r.map.labels) {
    r.level_cells += l == SafetyLabel::kLevel ? 1 : 0;
    r.inclined_cells += l == SafetyLabel::kInclined ? 1 : 0;
    r.non_ground_cells += l == SafetyLabel::kNonGround ? 1 : 0;
  }
  return true;
}

std::string loadStereoCalibration(const std::string& left_yaml, const std::string& right_yaml,
                                  StereoCameraModel* model) {
  if (model == nullptr) return "model must not be null";
  std::vector<double> P[2];
  int width = 0, height = 0;
  const std::string files[2] = {left_yaml, right_yaml};
  for (int k = 0; k < 2; ++k) {
    try {
      cv::FileStorage fs(files[k], cv::FileStorage::READ);
      if (!fs.isOpened()) return "cannot read " + files[k];
      fs["projection_matrix"]["data"] >> P[k];
      if (k == 0) {
        fs["image_width"] >> width;
        fs["image_height"] >> height;
      }
    } catch (const cv::Exception& e) {
      return "cannot parse " + files[k] + ": " + e.what();
    }
    if (P[k].size() != 12) return files[k] + ": projection_matrix must have 12 values";
  }
  StereoCameraModel m;
  m.fx = P[0][0];
  m.fy = P[0][5];
  m.cx = P[0][2];
  m.cy = P[0][6];
  m.cx_right = P[1][2];
  m.baseline = P[1][0] != 0.0 ? -P[1][3] / P[1][0] : 0.0;
  m.width = width;
  m.height = height;
  const std::string err = m.validate();
  if (!err.empty()) return "calibration " + left_yaml + ": " + err;
  *model = m;
  return "";
}

std::string loadRectifiedCalibText(const std::string& path, int width, int height,
                                   StereoCameraModel* model) {
  if (model == nullptr) return "model must not be null";
  std::ifstream f(path);
  if (!f) return "cannot read " + path;
  std::string token;
  StereoCameraModel m;
  m.width = width;
  m.height = height;
  bool have[4] = {false, false, false, false};
  while (f >> token) {
    const std::size_t eq = token.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = token.substr(0, eq);
    double v = 0.0;
    try {
      v = std::stod(token.substr(eq + 1));
    } catch (const std::exception&) {
      return path + ": bad value in '" + token + "'";
    }
    if (key == "f") {
      m.fx = m.fy = v;
      have[0] = true;
    } else if (key == "cx") {
      m.cx = m.cx_right = v;
      have[1] = true;
    } else if (key == "cy") {
      m.cy = v;
      have[2] = true;
    } else if (key == "baseline_m") {
      m.baseline = v;
      have[3] = true;
    }
  }
  if (!(have[0] && have[1] && have[2] && have[3])) return path + ": needs f, cx, cy, baseline_m";
  const std::string err = m.validate();
  if (!err.empty()) return path + ": " + err;
  *model = m;
  return "";
}

}  // namespace stereo_safety_map
