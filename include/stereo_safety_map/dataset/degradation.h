// Degradations of the synthetic stereo datasets: what a real wheelchair's camera and odometry add
// to the perfect renderer. Pose errors tf does not report (the chassis bobbing and a constant tilt
// of the true camera pose, a heading random walk and a distance scale error of the reported
// odometry) and image errors (noise, left/right gain mismatch, vertical misrectification, motion
// blur, vignetting, exposure changes, surfaces without grain). Every option has a documented
// default; none() is the undegraded path bit for bit. Deterministic from a seed. ROS-free.
//
// Use: applyToRender() on the camera and scene before building the StereoRenderer; per frame,
// OdometryErrorModel::next() gives the TRUE left optical pose to render from and the REPORTED
// base pose to publish as odom -> base_link; ImageDegrader::apply() on the rendered pair.
#pragma once

#include "stereo_safety_map/dataset/portable_random.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

struct DegradationConfig {
  // ---- odometry and chassis: pose errors that tf does not report ----
  /// Per-frame chassis pitch and roll (independent Gaussians, sigma [deg]) of the TRUE camera
  /// pose: the bobbing of a wheelchair on castors and soft tyres. Drawn anew on every frame in
  /// which the robot moves and held while it stands still (a stopped chassis does not bob, and
  /// a stationary frame then repeats its predecessor's view). In [0, 5].
  double chassis_jitter_deg = 0.5;
  /// Constant unreported chassis tilt of the TRUE pose [deg]: seat load, tyre pressure, a mount
  /// calibrated a little off. Pitch positive = the front dips (the camera looks further down, as
  /// StereoHeadConfig::pitch_deg), roll positive = the left side rises. In [-5, 5]. At 3 m a
  /// 0.5 deg pitch moves the ground 2.6 cm and tilts it by 0.5 deg against theta_T = 3 deg.
  double chassis_pitch_offset_deg = 0.5;
  double chassis_roll_offset_deg = 0.0;
  /// Heading random walk of the REPORTED pose: each frame in which the robot moves adds a
  /// Gaussian of this sigma [deg] to the reported yaw increment (after N moving frames the
  /// heading error has sd sigma * sqrt(N)). In [0, 2].
  double heading_walk_deg = 0.05;
  /// Distance scale error of the REPORTED translation: reported displacement = true displacement
  /// * (1 + e) (a wheel radius off by e; negative = reported too short). In [-0.5, 0.5].
  double distance_scale_error = 0.02;

  // ---- image formation ----
  /// Gaussian image noise [grey levels] set on the camera (StereoHeadConfig::noise_sigma);
  /// negative = keep the camera's own value. In [-1, 50]: use -1 or [0, 50].
  double noise_sigma = 3.0;
  /// Photometric mismatch of the right camera: right gain = camera's right_gain * (1 + this).
  /// In [-0.3, 0.3].
  double right_gain_mismatch = 0.04;
  /// Vertical misrectification: the right image shifted down by this many pixels (sub-pixel,
  /// bilinear), which breaks the epipolar-row assumption of the matcher. In [-3, 3] [px].
  double vertical_misrect_px = 0.2;
  /// Exposure time for motion blur [s], 0 = none; in [0, 0.1]. The blur is a linear kernel per
  /// image row centred on the pixel (the frame's stamp is mid-exposure): horizontally
  /// fx * |yaw rate| * T px (pure yaw moves the whole image sideways), vertically the flow of the
  /// ground plane under forward speed v at the row's depression angle a below the horizon,
  /// fx * |v| * T * sin^2(a) / mount_z * (1 + ((row - cy) / fx)^2) px (0 above the horizon). An
  /// approximation: the flow of the centre column, no sideways expansion, no flow of obstacles
  /// above the ground.
  double exposure_time_s = 0.008;
  /// Vignetting: brightness falls off as 1 - vignetting * (r / r_corner)^2 from the image centre
  /// (a quadratic stand-in for cos^4), i.e. this share is lost in the corners. In [0, 0.9].
  double vignetting = 0.15;
  /// Per-frame global gain jitter of both cameras (auto exposure hunting): gain 1 + sigma * N(0,
  /// 1) per frame. In [0, 0.5].
  double exposure_jitter = 0.03;
  /// Auto-exposure steps: every `exposure_step_period` frames the gain toggles between 1 and
  /// 1 + exposure_step (a square wave; period 0 = off). Step in [-0.9, 2], period >= 0.
  double exposure_step = 0.0;
  int exposure_step_period = 0;
  /// Surfaces without their centimetre-scale grain: grain 0 on every material (polished, painted
  /// or dusty-smooth scenes where stereo finds less to match).
  bool no_grain = false;

  /// The undegraded path: renderer and scene as they are, perfect poses. applyToRender,
  /// OdometryErrorModel and ImageDegrader leave everything bit-identical.
  static DegradationConfig none();
  /// The documented defaults above: a well-kept wheelchair with a decent camera.
  static DegradationConfig defaults();
  /// The upper ends: chassis 1.5 deg, heading walk 0.2 deg/frame, scale 5 %, tilt 1.5 / 1 deg,
  /// noise 8, right gain +10 %, misrectification 0.5 px, 20 ms exposure, vignetting 35 %,
  /// exposure jitter 10 % and a 20 % step every 40 frames, no grain.
  static DegradationConfig strong();

  bool isNone() const;  ///< every option off (noise kept)
  std::string validate() const;
  /// Every option as "key=value,key=value,..." (parseDegradation reads it back).
  std::string describe() const;
};

/// Parses a comma-separated spec: an optional preset first ("none", "default" or "strong";
/// "default" when it starts with an override), then overrides "key=value" whose keys are the
/// field names above (booleans true/false/1/0). E.g. "strong,no_grain=false,noise_sigma=5".
/// Returns an error naming the bad token (empty on success; `out` untouched on error).
std::string parseDegradation(const std::string& spec, DegradationConfig* out);

/// Applies the render-side options: noise and right gain to the camera, grain to the scene's
/// materials (scene may be null).
void applyToRender(const DegradationConfig& d, StereoHeadConfig* camera, Scene* scene);

/// Per-frame poses with the odometry errors. Feed every frame of sampleTrajectory() in order.
class OdometryErrorModel {
 public:
  OdometryErrorModel(const DegradationConfig& config, std::uint64_t seed);

  struct FramePoses {
    Eigen::Isometry3d true_base;              ///< the truth (odom -> base_link)
    Eigen::Isometry3d true_left_optical;      ///< true base * chassis tilt * mount: render this
    Eigen::Isometry3d reported_base;          ///< odometry: publish as odom -> base_link
    Eigen::Isometry3d reported_left_optical;  ///< reported base * mount (what the mapper assumes)
    double chassis_pitch_deg = 0.0;           ///< the tilt applied (offset + jitter)
    double chassis_roll_deg = 0.0;
  };

  /// The reported pose equals the truth at the first frame and then integrates the true
  /// increments (in the previous true base frame) scaled by 1 + distance_scale_error, with the
  /// heading walk added to each moving frame's yaw increment. A stationary frame (same pose as
  /// the previous one) changes nothing.
  FramePoses next(const RobotPose& truth, const StereoHeadConfig& head);
  void reset();

 private:
  DegradationConfig config_;
  std::uint64_t seed_;
  PortableRng rng_;
  bool started_ = false;
  RobotPose last_;
  double rep_x_ = 0.0, rep_y_ = 0.0, rep_yaw_ = 0.0;
  double jitter_pitch_deg_ = 0.0, jitter_roll_deg_ = 0.0;
};

/// Image-side degradations of one rendered pair (mono8 or bgr8): exposure (jitter and steps)
/// and vignetting, motion blur from the frame's motion, vertical misrectification of the right
/// image, and fresh noise that tops the rendered noise (head.noise_sigma) back up where the
/// linear filters averaged it down. Per-frame random parts depend on (seed, frame) only, so
/// frames may be processed in any order.
class ImageDegrader {
 public:
  ImageDegrader(const DegradationConfig& config, std::uint64_t seed);

  /// Gain of both cameras at `frame` (exposure jitter and steps).
  double exposureGain(std::uint64_t frame) const;
  /// Motion blur kernel at image row `row` [px]: (horizontal, vertical) length.
  Eigen::Vector2d blurAt(const RobotPose& motion, const StereoHeadConfig& head, int row) const;

  void apply(std::uint64_t frame, const RobotPose& motion, const StereoHeadConfig& head,
             cv::Mat* left, cv::Mat* right);

 private:
  DegradationConfig config_;
  std::uint64_t seed_;
  cv::Mat work_, out_;        // float scratch, reused
  std::vector<float> gauss_;  // unit Gaussians for the noise top-up
};

}  // namespace dataset
}  // namespace stereo_safety_map
