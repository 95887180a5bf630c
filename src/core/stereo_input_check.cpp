#include "stereo_safety_map/core/stereo_input_check.h"

#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

bool sameBytes(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  const std::size_t row = static_cast<std::size_t>(a.cols) * a.elemSize();
  for (int r = 0; r < a.rows; ++r) {
    if (std::memcmp(a.ptr(r), b.ptr(r), row) != 0) return false;
  }
  return true;
}

double contrast(const cv::Mat& grey) {
  cv::Scalar mean, stddev;
  cv::meanStdDev(grey, mean, stddev);
  return stddev[0];
}

}  // namespace

std::string StereoInputCheckConfig::validate() const {
  if (!std::isfinite(min_contrast) || min_contrast < 0.0 || min_contrast > 128.0) {
    return "min_contrast must be in [0, 128] grey levels (0 = off)";
  }
  return "";
}

const char* toString(StereoInputProblem p) {
  switch (p) {
    case StereoInputProblem::kNone:
      return "none";
    case StereoInputProblem::kLeftNoContrast:
      return "left image without contrast";
    case StereoInputProblem::kRightNoContrast:
      return "right image without contrast";
    case StereoInputProblem::kLeftFrozen:
      return "left camera frozen";
    case StereoInputProblem::kRightFrozen:
      return "right camera frozen";
    case StereoInputProblem::kBothFrozen:
      return "both cameras frozen";
    case StereoInputProblem::kBadImage:
      return "bad image";
  }
  return "invalid problem";
}

StereoInputCheck::StereoInputCheck(const StereoInputCheckConfig& config) {
  setConfig(config);
}

void StereoInputCheck::setConfig(const StereoInputCheckConfig& config) {
  const std::string err = config.validate();
  if (!err.empty()) throw std::invalid_argument("StereoInputCheckConfig: " + err);
  config_ = config;
}

void StereoInputCheck::reset() {
  has_previous_ = false;
}

StereoInputProblem StereoInputCheck::check(const cv::Mat& left, const cv::Mat& right,
                                           std::string* detail) {
  auto say = [detail](StereoInputProblem p, const std::string& text) {
    if (detail != nullptr) *detail = text;
    return p;
  };
  if (detail != nullptr) detail->clear();
  if (left.empty() || right.empty() || left.type() != CV_8UC1 || right.type() != CV_8UC1 ||
      left.size() != right.size()) {
    has_previous_ = false;
    return say(StereoInputProblem::kBadImage,
               "the stereo check needs two 8-bit grey images of one size");
  }
  const bool left_same = has_previous_ && sameBytes(left, previous_left_);
  const bool right_same = has_previous_ && sameBytes(right, previous_right_);
  left.copyTo(previous_left_);
  right.copyTo(previous_right_);
  has_previous_ = true;
  left_contrast_ = contrast(left);
  right_contrast_ = contrast(right);

  if (config_.min_contrast > 0.0) {
    const bool left_flat = left_contrast_ < config_.min_contrast;
    const bool right_flat = right_contrast_ < config_.min_contrast;
    if (left_flat || right_flat) {
      std::ostringstream os;
      os.precision(2);
      os << std::fixed << (left_flat ? "left" : "right") << " image has no contrast (grey level "
         << "std dev " << (left_flat ? left_contrast_ : right_contrast_) << " < min_image_contrast "
         << config_.min_contrast << "): camera covered, black or saturated?";
      return say(
          left_flat ? StereoInputProblem::kLeftNoContrast : StereoInputProblem::kRightNoContrast,
          os.str());
    }
  }
  if (config_.reject_frozen && (left_same || right_same)) {
    if (left_same && right_same) {
      return say(StereoInputProblem::kBothFrozen,
                 "both cameras frozen? The left and right images repeat the previous pair byte "
                 "for byte (a noiseless simulator: set reject_frozen_images false)");
    }
    return say(left_same ? StereoInputProblem::kLeftFrozen : StereoInputProblem::kRightFrozen,
               std::string(left_same ? "left" : "right") +
                   " image repeats the previous one byte for byte while the " +
                   (left_same ? "right" : "left") +
                   " one changes: " + (left_same ? "left" : "right") + " camera frozen?");
  }
  return StereoInputProblem::kNone;
}

}  // namespace stereo_safety_map
