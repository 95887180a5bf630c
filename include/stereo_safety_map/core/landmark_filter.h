// Point-landmark tracking that removes false positives from dense stereo (paper 001, Sec. 4.2).
//
// Every frame each landmark is associated with the observed point of smallest Eq. (12) cost
// (squared Mahalanobis distance of the locations, Eq. (9)-(10), plus an optional descriptor
// term, Eq. (11)), gated by a chi-square threshold on the location term; a matched landmark is
// updated by the Kalman filter of Eq. (2). Points inside no landmark's gate start temporary
// landmarks; a temporary landmark that collects min_matches matches within time_window seconds
// becomes permanent, otherwise it is removed (001 Sec. 4.2, "Removing False Positives").
//
// Candidate sets (001 leaves their construction open, "collecting all points less than a
// certain Euclidean distance"): the stereo error is isotropic in (row, col, disparity), so the
// chi-square gate of a landmark is a small ellipse of a few pixels around its projection into
// the current image, whereas in the fixed frame it is a needle along the viewing ray that is
// decimetres long at 5 m (its depth sigma grows as Z^2). A fixed-frame voxel hash would either
// clip that needle or return hundreds of candidates per landmark. The frame's points are
// therefore bucketed per pixel by a counting sort (a voxel index of the image plane, cell = one
// pixel, which measured fastest), and each landmark scans, row by row, only the buckets under
// the first-order image of its gate: the ellipse of the 2x2 pixel covariance of point minus
// landmark. It loses no candidate that the gate accepts, except where capped at
// max_search_radius_px. The exact test is then Eq. (9) in 3D, after the cheaper marginal tests.
// Landmarks are visited in image-row order so that the scan walks the buckets nearly in order.
//
// One-to-one association (001 assumes a point belongs to exactly one landmark): when two
// landmarks pick the same point, the one more likely to have produced it keeps it, by the full
// Gaussian negative log-likelihood d^2 + ln det(S) (Eq. (12) can drop ln det(S) when it compares
// points for one landmark, but not between landmarks: without it a new, uncertain landmark on the
// same ray steals observations from an established one); the other goes without an update.
//
// Deviations from 001 (not in the paper):
// - New landmarks also respect the gates of landmarks started earlier in the same frame. 001's
//   rule ("points that do not lie within the Mahalanobis distance threshold of any landmark")
//   read per frame would start one landmark per pixel in the first frame and keep them all;
//   this way landmarks are about one gate apart, and every point in a gate still counts for the
//   keep mask. The permanent-landmark cloud is correspondingly sparser than the pixel grid.
// - The landmark descriptor is that of its latest matched point, not that of the past
//   observation with the closest viewing direction (for a robot that moves smoothly the latest
//   is the closest).
// - Landmarks farther than max_landmark_distance from the camera are dropped (a local, bounded
//   map); permanent landmarks in view that stop matching for stale_time are dropped (moved
//   objects); time going backwards (a replayed bag) resets the filter.
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_error_model.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// Parameters of the landmark filter. 001 gives no numbers except the chi-square rule; the
/// other defaults are chosen for a wheelchair at 10-15 frames/s and marked as such.
struct LandmarkFilterConfig {
  StereoErrorModelConfig error_model;  ///< pixel noise of Eq. (1)
  /// Gate on the squared Mahalanobis distance (001 Sec. 4.2, "No Matches and New Landmarks"):
  /// chi-square with 3 degrees of freedom at 99 % (11.345). Range (0, inf).
  double gate_chi2 = 11.345;
  /// false: the Euclidean baseline of 001 Fig. 4 (distance |x_p - mu_l| gated at euclidean_gate).
  bool use_mahalanobis = true;
  double euclidean_gate = 0.1;  ///< [m], (0, inf); used only when use_mahalanobis is false
  /// Matches a temporary landmark needs to become permanent, [1, 65535] (not in 001).
  int min_matches = 3;
  /// Seconds after its creation within which a temporary landmark must collect min_matches,
  /// (0, inf) (not in 001).
  double time_window = 1.0;
  /// A permanent landmark that projects into the image within [min_depth, max_depth] but has
  /// not been matched for this long is removed [s], (0, inf]; inf keeps permanent landmarks
  /// until they leave the local map (not in 001, which never removes permanent landmarks and
  /// assumes a static world).
  double stale_time = 2.0;
  int max_landmarks = 400000;  ///< capacity; new landmarks are refused beyond it, [1, 2^30]
  /// Cap on the half-size of a landmark's candidate window [px], [1, 256]. Bounds the cost of
  /// landmarks whose own covariance projects to a large window.
  double max_search_radius_px = 12.0;
  double min_depth = 0.2;  ///< points closer than this (camera z) are ignored [m], (0, max_depth)
  double max_depth = 8.0;  ///< points farther than this are ignored [m] (000's max_range)
  /// Landmarks farther than this from the camera are removed [m], [max_depth, inf).
  double max_landmark_distance = 10.0;
  /// Length of the optional per-point descriptor of Eq. (11)-(12), [0, kMaxDescriptorDim];
  /// 0 = locations only (001: "virtually indistinguishable" for dense stereo).
  int descriptor_dim = 0;
  /// Sigma_d = descriptor_sigma^2 I of Eq. (11), (0, inf).
  double descriptor_sigma = 1.0;

  static constexpr int kMaxDescriptorDim = 4;

  /// Empty when valid, otherwise a message naming the first offending parameter and its range.
  std::string validate() const;
};

enum class LandmarkStatus : std::uint8_t { kFree = 0, kTemporary = 1, kPermanent = 2 };

/// One tracked landmark: the Gaussian {mu, Sigma} of 001 Sec. 4.2 in the fixed frame.
struct Landmark {
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  Eigen::Matrix3f covariance = Eigen::Matrix3f::Zero();
  double first_stamp = 0.0;       ///< stamp of the point that started it [s]
  double last_match_stamp = 0.0;  ///< stamp of its latest match (or of its creation) [s]
  std::uint16_t matches = 0;      ///< frames in which a point matched it since its creation
  LandmarkStatus status = LandmarkStatus::kFree;
  float descriptor[LandmarkFilterConfig::kMaxDescriptorDim] = {0.f, 0.f, 0.f, 0.f};
};

/// Counters of one update() call.
struct LandmarkFilterStats {
  std::size_t points_in = 0;
  std::size_t points_invalid = 0;     ///< non-finite, outside [min_depth, max_depth] or image
  std::size_t points_matched = 0;     ///< points that updated a landmark (Eq. (2))
  std::size_t points_in_gate = 0;     ///< points inside at least one landmark's gate
  std::size_t points_kept = 0;        ///< points confirmed by a permanent landmark
  std::size_t candidates_tested = 0;  ///< point-landmark pairs scanned in candidate windows
  std::size_t landmarks_created = 0;
  std::size_t landmarks_promoted = 0;     ///< temporary -> permanent
  std::size_t landmarks_expired = 0;      ///< temporary landmarks removed (false positives)
  std::size_t landmarks_dropped_far = 0;  ///< beyond max_landmark_distance
  std::size_t landmarks_stale = 0;        ///< permanent, in view, unmatched for stale_time
  std::size_t landmarks_in_view = 0;      ///< landmarks given the association search
  std::size_t landmarks_refused = 0;      ///< not created: capacity reached
  std::size_t temporary = 0;              ///< after the update
  std::size_t permanent = 0;
  bool rejected = false;             ///< frame not used (non-finite pose or stamp)
  bool reset = false;                ///< stamp went backwards: the filter was cleared first
  bool descriptors_ignored = false;  ///< descriptors given with the wrong size
};

class LandmarkFilter {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty or the camera is unusable
  /// (see StereoErrorModel::checkCamera; width and height must also be > 0).
  LandmarkFilter(const StereoCameraModel& camera,
                 const LandmarkFilterConfig& config = LandmarkFilterConfig());

  const LandmarkFilterConfig& config() const { return config_; }
  const StereoErrorModel& errorModel() const { return error_model_; }

  /// Processes one frame. `points_camera` are in the left optical frame (e.g. from
  /// reprojectDisparity), `T_fixed_camera` maps them to the fixed frame, `stamp` in seconds.
  /// `keep_mask` (optional) is resized to points_camera.size(): 1 where the point lies in the
  /// gate of a landmark that is permanent after this update (a confirmed point, to be passed
  /// on to the voxel grid), 0 otherwise. `descriptors` (optional) holds descriptor_dim floats
  /// per point, point-major. Does not allocate once its buffers have grown to the frame size
  /// and the landmark store to its working size.
  const LandmarkFilterStats& update(const std::vector<Eigen::Vector3f>& points_camera,
                                    const Eigen::Isometry3f& T_fixed_camera, double stamp,
                                    std::vector<std::uint8_t>* keep_mask = nullptr,
                                    const std::vector<float>* descriptors = nullptr);

  /// Stats of the last update().
  const LandmarkFilterStats& stats() const { return stats_; }

  /// Means of the permanent landmarks (fixed frame), the filter's own output cloud. `out` is
  /// reused.
  void permanentLandmarks(std::vector<Eigen::Vector3f>* out) const;

  /// All landmark slots; those with status kFree are unused.
  const std::vector<Landmark>& landmarks() const { return landmarks_; }
  std::size_t numPermanent() const { return num_permanent_; }
  std::size_t numTemporary() const { return num_temporary_; }

  /// Per input point of the last update(): the landmark slot it updated, or -1.
  const std::vector<std::int32_t>& associations() const { return associations_; }

  /// Removes every landmark.
  void clear();

 private:
  static constexpr int kLanes = 4;  // candidates per packet in scanGate()

  void bucketPoints(const std::vector<Eigen::Vector3f>& points);
  void associate(const Eigen::Isometry3d& T, bool use_descriptors,
                 const std::vector<float>* descriptors);
  void updateMatched(const Eigen::Isometry3d& T, bool use_descriptors,
                     const std::vector<float>* descriptors);
  void createLandmarks(const Eigen::Isometry3d& T, double stamp, bool use_descriptors,
                       const std::vector<float>* descriptors);
  void removeLandmark(std::int32_t slot);
  // Calls fn(sorted index, d^2, det S) for every point of the frame inside the gate of a
  // landmark at pc (camera frame) with camera-frame covariance L.
  template <typename Fn>
  void scanGate(const Eigen::Vector3d& pc, const Eigen::Matrix3d& L, Fn&& fn);

  LandmarkFilterConfig config_;
  StereoErrorModel error_model_;
  StereoCameraModel camera_;
  double inv_desc_var_ = 1.0;
  double gate_ = 0.0;  // gate_chi2, or euclidean_gate^2
  double inv_fx_ = 0.0, inv_fy_ = 0.0, inv_fb_ = 0.0;
  double sr2_ = 0.0, sc2_ = 0.0, sd2_ = 0.0;

  std::vector<Landmark> landmarks_;
  std::vector<std::int32_t> free_slots_;
  std::size_t num_permanent_ = 0, num_temporary_ = 0;
  double last_stamp_ = 0.0;
  bool has_stamp_ = false;
  double stamp_ = 0.0;

  // Per-frame buffers, reused.
  std::vector<std::int32_t> bucket_start_;  // per pixel (row-major) + 1: offsets into sorted
  std::vector<std::int32_t> point_bucket_;  // per input point, -1 when invalid
  // The valid points in pixel order (camera frame, structure of arrays for the packet scan,
  // padded by kLanes), and their input indices.
  std::vector<float> sorted_x_, sorted_y_, sorted_z_;
  std::vector<std::int32_t> sorted_index_;
  std::size_t num_sorted_ = 0;
  std::vector<std::int32_t> owner_;    // per sorted point: landmark that took it, or -1
  std::vector<float> owner_cost_;      // its Eq. (12) cost
  std::vector<double> owner_det_;      // and det(S), for conflicts
  std::vector<std::int32_t> nearest_;  // per sorted point: in-gate landmark of least d^2
  std::vector<float> nearest_d2_;
  std::vector<std::uint8_t> near_permanent_;  // in the gate of a landmark permanent at scan time
  std::vector<std::uint8_t> covered_;         // in the gate of a landmark started in this frame
  std::vector<std::int32_t> associations_;
  // A landmark in view as pass 2 of associate() needs it: camera-frame mean and covariance.
  struct VisitRecord {
    Eigen::Vector3d pc;
    Eigen::Matrix3d L;
    std::int32_t slot;
    std::uint8_t permanent;
  };
  std::vector<VisitRecord> visit_unsorted_, visit_sorted_;  // slot order, image-row order
  std::vector<std::int32_t> visit_row_, visit_row_start_;
  LandmarkFilterStats stats_;
};

/// Copies the points whose mask entry is non-zero (the filtered stream for the voxel grid).
/// `out` is reused; a mask of the wrong size copies nothing.
void applyKeepMask(const std::vector<Eigen::Vector3f>& points,
                   const std::vector<std::uint8_t>& keep_mask, std::vector<Eigen::Vector3f>* out);

// ---------------------------------------------------------------------------------------------
// The landmark filter as a filter of the point stream before the voxel grid.
//
// 001 Sec. 4.2 builds its 3D model from permanent landmarks only. Used in front of paper 000's
// voxel grid, a frame's point passes when it lies in the gate of a landmark that is permanent
// after the frame's update (LandmarkFilter's keep mask): points that no landmark has confirmed
// over min_matches frames within time_window, i.e. one-frame mismatches, never reach the grid.
// The first frames (before any landmark is permanent) pass nothing. StereoFrameProcessor (the
// offline tools) and the safety-map nodelet share this class, so that both filter alike.
//
// The filter needs frames taken from different poses (001: "removing noise from dense stereo
// data using motion"): a mismatch repeats in every frame of a stationary camera and would be
// confirmed. The stream filter therefore skips frames taken while the camera has not moved since
// the last frame it used, with the voxel grid's thresholds (000 Sec. IV), also before the grid has
// integrated anything; the caller drops such frames, as the grid would.

struct SafetyMapperConfig;

/// Whether and how the stream is filtered (a parameter of the safety-map pipeline).
struct LandmarkStreamConfig {
  bool enabled = false;  ///< off: 000's pipeline as published; on: 001's filter in front of it
  LandmarkFilterConfig filter;
  /// Frames from a camera that moved less than both thresholds since the last frame the filter
  /// used are skipped (000 Sec. IV's rule for the grid; forMapper() copies the grid's values).
  bool skip_stationary_frames = true;
  double stationary_translation = 0.02;  ///< [m], [0, 100]
  double stationary_rotation_deg = 1.0;  ///< [deg], [0, 180]

  /// This configuration for the voxel grid it feeds: the filter's depth range is the grid's
  /// [min_range, max_range] (min_depth at least 1 mm; max_landmark_distance raised to max_range
  /// when smaller) and stationary frames are those the mapper skips.
  LandmarkStreamConfig forMapper(const SafetyMapperConfig& mapper) const;
  /// Empty when valid (also while disabled), else why not.
  std::string validate() const;
};

/// What LandmarkStreamFilter::apply() did with a frame.
enum class LandmarkStreamStatus : std::uint8_t {
  kFiltered = 0,    ///< points filtered (possibly to none: no landmark is permanent yet)
  kStationary = 1,  ///< the camera has not moved: frame not used, to be dropped by the caller
  kRejected = 2,    ///< unusable camera, non-finite pose or stamp: frame not used
};

class LandmarkStreamFilter {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit LandmarkStreamFilter(const LandmarkStreamConfig& config = LandmarkStreamConfig());

  /// Runs the filter on one frame and removes from `*points` (camera frame, e.g. from
  /// reprojectDisparity) every point that no permanent landmark confirms; the order of the kept
  /// points is preserved. `camera` is the frame's camera (a change of geometry restarts the
  /// filter: landmarks live in image coordinates). kStationary and kRejected (with *error set)
  /// leave *points untouched; the caller drops the frame.
  LandmarkStreamStatus apply(const StereoCameraModel& camera,
                             const Eigen::Isometry3f& T_fixed_camera, double stamp,
                             std::vector<Eigen::Vector3f>* points, std::string* error = nullptr);

  /// Forgets every landmark (the next frame starts afresh).
  void reset();

  /// Stats of the last apply() that filtered (empty before the first).
  const LandmarkFilterStats& stats() const { return stats_; }
  /// Wall time of the last apply() [ms].
  double lastMs() const { return last_ms_; }
  /// CPU time of the calling thread in the last apply() [ms] (less disturbed by a busy machine
  /// than the wall time).
  double lastCpuMs() const { return last_cpu_ms_; }
  /// The filter (null before the first frame).
  const LandmarkFilter* filter() const { return filter_.get(); }
  /// Means of the permanent landmarks (fixed frame), the filter's own output; `out` is reused.
  void permanentLandmarks(std::vector<Eigen::Vector3f>* out) const;
  /// Times the filter was restarted for a new camera geometry.
  std::size_t cameraChanges() const { return camera_changes_; }

 private:
  LandmarkStreamConfig config_;
  std::unique_ptr<LandmarkFilter> filter_;
  StereoCameraModel camera_;
  bool has_last_pose_ = false;
  Eigen::Isometry3f last_pose_ = Eigen::Isometry3f::Identity();
  std::vector<std::uint8_t> keep_;
  LandmarkFilterStats stats_;
  double last_ms_ = 0.0;
  double last_cpu_ms_ = 0.0;
  std::size_t camera_changes_ = 0;
};

}  // namespace stereo_safety_map
