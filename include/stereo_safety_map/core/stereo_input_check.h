// Checks of a rectified stereo pair for a degraded camera before matching (ours, not in the
// papers): an image without contrast (lens covered, camera black or saturated) and an image that
// repeats the previous one byte for byte (a frozen camera or driver re-sending its last buffer;
// a real sensor's noise never repeats a frame).
//
// Matching such a pair does not fail loudly: a black or frozen right image against a live left
// one gives a few confident-looking wrong disparities, whose rays would clear free space through
// real obstacles in the voxel grid (000 Sec. IV). So the pair is refused, with what is wrong.
//
// ROS-free. One instance per camera pair: it keeps a copy of the previous pair.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>

namespace stereo_safety_map {

struct StereoInputCheckConfig {
  /// Smallest standard deviation of an image's grey levels; below it the image cannot give a
  /// disparity (the texture test of 002 Sec. 2.2 would remove every pixel anyway) and the camera
  /// is reported covered, black or saturated. 0 = off. [grey levels]
  double min_contrast = 2.0;
  /// Refuse a pair in which an image is byte for byte the previous pair's. Off for noiseless
  /// simulators that repeat frames while the robot stands still.
  bool reject_frozen = true;

  /// Empty when valid, otherwise a message naming the offending parameter and its range.
  std::string validate() const;
};

enum class StereoInputProblem : std::uint8_t {
  kNone = 0,
  kLeftNoContrast,
  kRightNoContrast,
  kLeftFrozen,   ///< left repeats the previous left image, right does not
  kRightFrozen,  ///< right repeats the previous right image, left does not
  kBothFrozen,   ///< both repeat the previous pair
  kBadImage,     ///< empty, not 8-bit single-channel, or left and right differ in size
};
const char* toString(StereoInputProblem p);

class StereoInputCheck {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit StereoInputCheck(const StereoInputCheckConfig& config = StereoInputCheckConfig());

  const StereoInputCheckConfig& config() const { return config_; }
  void setConfig(const StereoInputCheckConfig& config);  ///< throws like the constructor

  /// Checks one pair of 8-bit grey images (any row step) and remembers it as the previous pair,
  /// whatever the verdict. `detail` (optional) gets a one-line explanation of a problem.
  StereoInputProblem check(const cv::Mat& left, const cv::Mat& right,
                           std::string* detail = nullptr);

  /// Forgets the previous pair (the next pair cannot be frozen).
  void reset();

  /// Standard deviation of the grey levels of the last pair checked.
  double lastLeftContrast() const { return left_contrast_; }
  double lastRightContrast() const { return right_contrast_; }

 private:
  StereoInputCheckConfig config_;
  cv::Mat previous_left_, previous_right_;  // continuous copies, reused
  bool has_previous_ = false;
  double left_contrast_ = 0.0;
  double right_contrast_ = 0.0;
};

}  // namespace stereo_safety_map
