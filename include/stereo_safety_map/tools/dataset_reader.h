// Reading the package's benchmark datasets (bags made by make_dataset) without a roscore, for the
// offline tools (evaluation, benchmarks): the ground truth of a dataset, the stereo pairs of its
// bag with the camera model, camera pose and robot position from the bag's tf. The nodelets' flat
// parameter files are applied to the core's configuration by ros/param_yaml.h (loadCoreParams,
// setCoreParam), the one YAML reader of the field lists.
//
// Every offline tool goes through this one reader, so that all of them see exactly the frames
// and poses the safety-map nodelet sees (DEVELOPERS.md: how a frame flows). Tool support: built
// into the stereo_safety_map_tools library (src/tools/tool_support/), which the tools and the
// tests that replay a dataset link; it may use the ROS layer, never the other way round.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"

#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace stereo_safety_map {

// ---------------------------------------------------------------------------------------------
// Ground truth of a dataset: labels from the bag's latched /ground_truth/labels (or
// <bag>_gt/gt_labels.pgm), planes, boards and obstacles from <bag>_gt/*.yaml (scenes/README.md).

struct DatasetBoard {
  std::string name;
  BoardBox box;
};

/// One obstacle of <bag>_gt/gt_obstacles.yaml: an oriented box around the object (for poles
/// and railings the box around them), its type as in the scene file.
struct DatasetObstacle {
  std::string name;
  std::string type;
  BoardBox box;
};

struct Dataset {
  std::string name;    ///< bag file name without .bag
  std::string bag;     ///< path of the bag
  std::string gt_dir;  ///< <bag>_gt
  LabelGrid gt;
  std::vector<ReferencePlane> planes;
  std::vector<DatasetBoard> boards;
  std::vector<DatasetObstacle> obstacles;  ///< every entry of gt_obstacles.yaml, boards included
  std::string scene;                       ///< scene name from dataset.yaml
  bool latency_only = false;
  bool untextured = false;
  std::string note;  ///< what is missing (e.g. no planes)
};

/// Loads the ground truth of the dataset `bag`. Empty on success, else why not.
std::string loadDataset(const std::string& bag, bool latency_only, Dataset* d);

// ---------------------------------------------------------------------------------------------
// Stereo pairs of a dataset bag.

struct StereoBagFrame {
  int index = -1;  ///< 0-based index of the stereo pair in the bag
  ros::Time stamp;
  std::string frame_id;  ///< left optical frame
  /// Empty when the pair is usable; otherwise why not (no camera_info yet, camera model, tf,
  /// image conversion). The fields below are then only partly set.
  std::string error;
  cv::Mat left, right;  ///< 8-bit, shared with the messages (do not write)
  sensor_msgs::ImageConstPtr left_msg, right_msg;
  sensor_msgs::CameraInfoConstPtr left_info, right_info;
  StereoCameraModel camera;
  Eigen::Isometry3d T_fixed_sensor = Eigen::Isometry3d::Identity();  ///< left optical frame
  Eigen::Isometry3d T_fixed_base = Eigen::Isometry3d::Identity();
  Eigen::Vector3d robot = Eigen::Vector3d::Zero();  ///< base position in the fixed frame
  /// The newest scan stamped at or before the pair (null when the bag has none yet), and the
  /// pose of its frame in the fixed frame at the scan's stamp (valid when scan_pose_ok).
  sensor_msgs::LaserScanConstPtr scan;
  Eigen::Isometry3d T_fixed_scan = Eigen::Isometry3d::Identity();
  bool scan_pose_ok = false;
};

struct StereoBagReaderOptions {
  std::string camera = "stereo";  ///< namespace: /<camera>/{left,right}/{image_rect,camera_info}
  std::string fixed_frame = "odom";
  std::string base_frame = "base_link";
  std::string scan_topic = "/scan";  ///< empty: no scans
  long max_frames = -1;              ///< stop after this many pairs (-1: all)
};

/// Reads the stereo pairs of a bag in stamp order, with tf from the bag's /tf and /tf_static
/// (a tf2::BufferCore covering the whole bag).
class StereoBagReader {
 public:
  StereoBagReader();
  ~StereoBagReader();
  StereoBagReader(const StereoBagReader&) = delete;
  StereoBagReader& operator=(const StereoBagReader&) = delete;

  /// Empty on success, else why the bag cannot be read.
  std::string open(const std::string& bag, const StereoBagReaderOptions& options = {});

  /// Next stereo pair; false at the end of the bag (or after max_frames pairs). A pair that
  /// cannot be used is still returned, with `error` set.
  bool next(StereoBagFrame* frame);

  /// Number of stereo pairs (left images, limited by max_frames).
  int pairCount() const { return pair_count_; }
  /// Duration of the bag [s].
  double bagSeconds() const { return bag_seconds_; }
  const tf2::BufferCore& tf() const { return *tf_; }
  const StereoBagReaderOptions& options() const { return options_; }

 private:
  struct Pending {
    sensor_msgs::ImageConstPtr left, right;
  };
  StereoBagReaderOptions options_;
  rosbag::Bag bag_;
  std::unique_ptr<tf2::BufferCore> tf_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
  std::map<ros::Time, Pending> pending_;
  sensor_msgs::CameraInfoConstPtr left_info_, right_info_;
  sensor_msgs::LaserScanConstPtr scan_;
  std::string t_left_, t_right_, t_linfo_, t_rinfo_;
  int pair_count_ = 0;
  int index_ = -1;
  double bag_seconds_ = 0.0;
};

/// Heading of a camera's optical axis projected on the ground [rad].
double yawOfOpticalAxis(const Eigen::Isometry3d& T_fixed_sensor);

// ---------------------------------------------------------------------------------------------
// Small file helpers for the tools.

bool makeDirs(const std::string& path);
bool fileExists(const std::string& path);
/// File name without directory and without a .bag extension.
std::string bagBaseName(const std::string& path);

}  // namespace stereo_safety_map
