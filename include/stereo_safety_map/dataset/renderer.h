// Deterministic stereo renderer for the synthetic datasets: one ray per pixel against the scene's
// convex solids, procedural textures evaluated on the surface in world coordinates (so the left and
// right images agree wherever stereo could match), Lambert + ambient shading, optional optical blur
// and Gaussian image noise. Both images are rectified by construction: the right camera is the left
// one translated by the baseline along its x axis, with the same intrinsics, so a point at depth Z
// appears fB/Z pixels further left in the right image (002 Sec. 3.2). ROS-free.
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/dataset/scene.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

/// A wheelchair's stereo head: intrinsics, mounting on base_link, and image formation.
struct StereoHeadConfig {
  int width = 640;         ///< [px]
  int height = 480;        ///< [px]
  double hfov_deg = 60.0;  ///< horizontal field of view, in [20, 120] [deg]
  double baseline = 0.12;  ///< [m], in (0, 1]
  /// Position of the left camera's optical centre in base_link [m]. y = baseline / 2 centres the
  /// pair on the robot's axis.
  double mount_x = 0.25;
  double mount_y = 0.06;
  double mount_z = 1.1;
  double pitch_deg = 22.0;   ///< downward tilt of the optical axis, in [-10, 80] [deg]
  double near_clip = 0.05;   ///< nearest rendered depth [m]
  double max_depth = 200.0;  ///< farther hits are background [m]

  double exposure = 1.0;     ///< grey = 255 * exposure * radiance
  double noise_sigma = 2.0;  ///< Gaussian image noise [grey levels], in [0, 50]
  double blur_sigma = 0.5;   ///< optical blur [px], 0 = off, in [0, 5]
  double right_gain = 1.0;   ///< photometric mismatch of the right camera, in [0.5, 2]
  bool colour = false;       ///< bgr8 images instead of mono8
  int threads = 2;           ///< worker threads, in [1, 64] (the output does not depend on it)

  std::string validate() const;

  double fx() const;  ///< = fy, square pixels
  double cx() const { return 0.5 * (width - 1); }
  double cy() const { return 0.5 * (height - 1); }

  /// Same field of view and mounting at another resolution (the small test datasets).
  StereoHeadConfig scaledTo(int new_width, int new_height) const;

  /// Pose of the camera body frame (x forward, y left, z up, pitched down) in base_link.
  Eigen::Isometry3d baseToCameraLink() const;
  /// Pose of the left optical frame (x right, y down, z forward) in base_link.
  Eigen::Isometry3d baseToLeftOptical() const;
};

/// The core's model of the rectified pair the renderer makes from `head` (square pixels, same
/// principal point in both images, the right camera `baseline` along x).
StereoCameraModel stereoCameraModel(const StereoHeadConfig& head);

/// Rotation from a camera body frame (x fwd, y left, z up) to its optical frame (REP 103).
Eigen::Matrix3d linkToOpticalRotation();

/// Planar base pose (x, y, z, yaw) as an isometry.
Eigen::Isometry3d basePose(double x, double y, double z, double yaw);

class StereoRenderer {
 public:
  /// Copies the scene. Throws std::invalid_argument when the scene or config is invalid.
  StereoRenderer(const Scene& scene, const StereoHeadConfig& config, std::uint64_t seed);

  const StereoHeadConfig& config() const { return config_; }
  const Scene& scene() const { return scene_; }

  /// Renders the stereo pair seen from the left optical frame pose `T_world_left`. `frame`
  /// selects the image noise (same seed + frame = same images). Outputs are (re)allocated only
  /// when their size or type changes: mono8 (CV_8UC1) or bgr8 (CV_8UC3). Optional outputs of the
  /// left camera: depth Z [m] along the optical axis (CV_32F, +inf where nothing is hit) and the
  /// index of the primitive seen (CV_32S, -1 where none). Rows are shared among
  /// config().threads workers started per call (tens of microseconds against ~100 ms of work).
  /// Returns false (outputs untouched) when the pose is not finite.
  bool render(const Eigen::Isometry3d& T_world_left, std::uint64_t frame, cv::Mat* left,
              cv::Mat* right, cv::Mat* left_depth = nullptr, cv::Mat* left_ids = nullptr);

  /// The left camera's depth Z [m] along the optical axis (CV_32F, +inf where nothing is hit)
  /// and optionally the primitive seen (CV_32S, -1 where none) from `T_world_left`, cast exactly
  /// as render() casts them, without shading either image: the exact geometry of a frame (test
  /// disparities and clouds). Returns false (outputs untouched) when the pose is not finite.
  bool renderDepth(const Eigen::Isometry3d& T_world_left, cv::Mat* left_depth,
                   cv::Mat* left_ids = nullptr);

  /// Noise-free radiance of one ray (for tests): grey level before noise, blur and quantisation.
  float shadeRay(const Ray& ray, double t_min, Hit* hit = nullptr) const;

 private:
  struct View {
    Eigen::Matrix3d R;                       // camera -> world rotation
    Eigen::Vector3d origin;                  // optical centre in world
    std::vector<std::vector<int>> tiles;     // primitive indices whose image bounds touch each tile
    std::vector<Eigen::Vector3d> hull, pts;  // culling scratch, reused
  };

  void cullTiles(View* view) const;
  void renderBand(int cam, int tile_row, std::uint64_t frame);
  Eigen::Vector3f shade(const Ray& ray, const Hit& hit, double footprint_scale) const;
  Eigen::Vector3f background(const Eigen::Vector3d& dir) const;

  Scene scene_;
  StereoHeadConfig config_;
  std::uint64_t seed_;
  double fx_;
  int tiles_x_ = 0, tiles_y_ = 0;
  View views_[2];
  cv::Mat radiance_[2];  // CV_32FC1 or CV_32FC3
  cv::Mat blurred_[2];
  cv::Mat depth_;  // CV_32F, left
  cv::Mat ids_;    // CV_32S, left
  bool want_aux_ = false;
  bool depth_only_ = false;         // renderDepth(): cast the left rays, shade nothing
  std::vector<float> gauss_table_;  // unit normal samples for the image noise
};

}  // namespace dataset
}  // namespace stereo_safety_map
