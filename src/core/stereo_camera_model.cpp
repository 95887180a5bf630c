#include "stereo_safety_map/core/stereo_camera_model.h"

#include <cmath>
#include <limits>
#include <sstream>

namespace stereo_safety_map {

namespace {

std::string notPositive(const char* name, double value) {
  std::ostringstream s;
  s << name << " = " << value << " must be finite and > 0";
  return s.str();
}

// Shared input check of the reprojection helpers: a usable model whose image size is the
// disparity image's (a disparity of another resolution would need another model).
bool usable(const cv::Mat& disparity, const StereoCameraModel& model) {
  return !disparity.empty() && disparity.dims == 2 && disparity.type() == CV_32FC1 &&
         model.validate().empty() && disparity.cols == model.width &&
         disparity.rows == model.height;
}

}  // namespace

std::string StereoCameraModel::validate() const {
  if (!(std::isfinite(fx) && fx > 0.0)) return notPositive("fx", fx);
  if (!(std::isfinite(fy) && fy > 0.0)) return notPositive("fy", fy);
  if (!(std::isfinite(baseline) && baseline > 0.0)) return notPositive("baseline", baseline);
  if (!std::isfinite(cx) || !std::isfinite(cy) || !std::isfinite(cx_right)) {
    return "cx, cy and cx_right must be finite";
  }
  if (width <= 0 || height <= 0) {
    std::ostringstream s;
    s << "image size " << width << " x " << height << " must be positive";
    return s.str();
  }
  return {};
}

// Z = f B / (d - (cx - cx_right)) (002, Sec. 3.2), X = (x - cx) Z / fx, Y = (y - cy) Z / fy.
// Invalid inputs (empty or non CV_32FC1 image, invalid model, model size != image size, step < 1)
// produce no points. Float arithmetic with row constants hoisted; one division per kept pixel.
DisparityMessageGeometry disparityMessageGeometry(const StereoCameraModel& camera,
                                                  int min_disparity, int num_disparities) {
  DisparityMessageGeometry g;
  g.f = static_cast<float>(camera.fx);
  g.T = static_cast<float>(camera.baseline);
  g.offset = static_cast<float>(camera.cx - camera.cx_right);
  g.min_disparity = static_cast<float>(min_disparity) - g.offset;
  g.max_disparity = static_cast<float>(min_disparity + num_disparities - 1) - g.offset;
  return g;
}

void throughDisparityMessage(const DisparityMessageGeometry& g, cv::Mat* disparity) {
  if (disparity == nullptr || disparity->type() != CV_32FC1) return;
  for (int r = 0; r < disparity->rows; ++r) {
    float* d = disparity->ptr<float>(r);
    for (int c = 0; c < disparity->cols; ++c)
      d[c] = g.fromMessage(g.toMessage(d[c]));
  }
}

StereoCameraModel messageCameraModel(const DisparityMessageGeometry& g,
                                     const StereoCameraModel& left) {
  StereoCameraModel m = left;
  m.fx = g.f;
  m.fy = left.fy * g.f / left.fx;  // keeps the aspect ratio if f was rescaled
  m.cx_right = m.cx;               // the message's disparities have the offset removed
  m.baseline = g.T;
  return m;
}

void reprojectDisparity(const cv::Mat& disparity, const StereoCameraModel& model, double min_depth,
                        double max_depth, int step, std::vector<Eigen::Vector3f>* points) {
  if (points == nullptr) return;
  points->clear();
  if (!usable(disparity, model) || step < 1 || std::isnan(min_depth) || std::isnan(max_depth)) {
    return;
  }
  // In size_t: rows + step - 1 overflows an int for a huge step (fuzzing found it).
  const std::size_t st = static_cast<std::size_t>(step);
  const std::size_t max_points = ((static_cast<std::size_t>(disparity.rows) + st - 1) / st) *
                                 ((static_cast<std::size_t>(disparity.cols) + st - 1) / st);
  // One allocation on the first call, none afterwards (capacity is kept by clear()).
  if (points->capacity() < max_points) points->reserve(max_points);

  const float focal_baseline = static_cast<float>(model.fx * model.baseline);
  const float offset = static_cast<float>(model.cx - model.cx_right);
  const float cx = static_cast<float>(model.cx);
  const float inv_fx = static_cast<float>(1.0 / model.fx);
  const float z_min = static_cast<float>(min_depth);
  const float z_max = static_cast<float>(max_depth);
  constexpr float kMaxFinite = std::numeric_limits<float>::max();

  for (int y = 0; y < disparity.rows; y += step) {
    const float* row = disparity.ptr<float>(y);
    const float y_norm = static_cast<float>((y - model.cy) / model.fy);
    for (int x = 0; x < disparity.cols; x += step) {
      const float d = row[x];
      // Invalid = <= 0 or non-finite (NaN fails every comparison).
      if (!(d > 0.0f && d <= kMaxFinite)) continue;
      const float shifted = d - offset;
      if (!(shifted > 0.0f)) continue;  // at or beyond infinity
      const float z = focal_baseline / shifted;
      if (!(z >= z_min && z <= z_max)) continue;
      points->emplace_back((static_cast<float>(x) - cx) * inv_fx * z, y_norm * z, z);
    }
  }
}

// Organised output, NaN for invalid pixels and for Z > max_depth. Invalid inputs release *xyz.
void reprojectDisparityOrganized(const cv::Mat& disparity, const StereoCameraModel& model,
                                 double max_depth, cv::Mat* xyz) {
  if (xyz == nullptr) return;
  if (!usable(disparity, model) || std::isnan(max_depth)) {
    xyz->release();
    return;
  }
  xyz->create(disparity.rows, disparity.cols, CV_32FC3);

  const float focal_baseline = static_cast<float>(model.fx * model.baseline);
  const float offset = static_cast<float>(model.cx - model.cx_right);
  const float cx = static_cast<float>(model.cx);
  const float inv_fx = static_cast<float>(1.0 / model.fx);
  const float z_max = static_cast<float>(max_depth);
  constexpr float kMaxFinite = std::numeric_limits<float>::max();
  const float nan = std::numeric_limits<float>::quiet_NaN();

  for (int y = 0; y < disparity.rows; ++y) {
    const float* row = disparity.ptr<float>(y);
    cv::Vec3f* out = xyz->ptr<cv::Vec3f>(y);
    const float y_norm = static_cast<float>((y - model.cy) / model.fy);
    for (int x = 0; x < disparity.cols; ++x) {
      const float d = row[x];
      const float shifted = d - offset;
      out[x] = cv::Vec3f(nan, nan, nan);
      if (!(d > 0.0f && d <= kMaxFinite && shifted > 0.0f)) continue;
      const float z = focal_baseline / shifted;
      if (z <= z_max) out[x] = cv::Vec3f((static_cast<float>(x) - cx) * inv_fx * z, y_norm * z, z);
    }
  }
}

std::size_t limitRangeImageDepth(double min_depth, double max_depth, cv::Mat* xyz) {
  if (xyz == nullptr || xyz->empty() || xyz->type() != CV_32FC3) return 0;
  const float lo = static_cast<float>(min_depth), hi = static_cast<float>(max_depth);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::size_t valid = 0;
  for (int r = 0; r < xyz->rows; ++r) {
    cv::Vec3f* p = xyz->ptr<cv::Vec3f>(r);
    for (int c = 0; c < xyz->cols; ++c) {
      if (p[c][2] >= lo && p[c][2] <= hi) {
        ++valid;
      } else {
        p[c] = cv::Vec3f(nan, nan, nan);
      }
    }
  }
  return valid;
}

}  // namespace stereo_safety_map
