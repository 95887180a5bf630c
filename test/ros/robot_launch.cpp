// robot.launch as the wheelchair runs it (test/ros/robot_launch.test includes it, no hardware):
// the test node is the camera and the odometry. On simulated time, in lockstep at 10 Hz, it
// renders scenes/dataset1_rail_dropoff_ramp.yaml (paper 000's dataset 1: a 35 cm drop-off left
// of a centre rail) with the package's renderer at 320x240 while the chair drives towards the
// drop-off, and publishes the rectified pair, CameraInfo, /clock and tf odom -> base_footprint
// (REP 120's footprint frame, robot.launch's default base frame); robot.launch publishes
// base_footprint -> camera (camera_tf:=true with the head's mounting). The chair stands at the
// start until the first map comes back (the chain is connected), then every frame is counted.
//
// Checked: robot.launch's nodes are wired (our disparity nodelet on the camera's image_rect, the
// safety map on its disparity, the gate on the map): every frame's map is published, in odom, with
// the chair's cell Level; the gate answers a command. And the map of dataset 1 has potential
// drop-off edges (000 Sec. VI) where the plaza's edge is, lethal in the OccupancyGrid, and drawn
// by their own rviz marker (planes, namespace drop_off_edges). And robot.launch's obstacle
// detector (paper 003, obstacles:=true by default, with its stereo noise margin noise_sigmas 1)
// publishes the safety map's obstacle cue: raised points on the centre rail, none on the open
// plaza the chair drives over.
#include "disparity_test_util.h"
#include "sim_clock.h"
#include "test_util.h"

#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/ros/msgs.h"

#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

using stereo_safety_map::GateStateMsg;
using stereo_safety_map::SafetyMapMsg;
namespace ds = stereo_safety_map::dataset;

namespace {

constexpr double kDt = 0.1;      // [s] frame period
constexpr double kWaitS = 15.0;  // [s] wall-clock wait for a map or a decision
constexpr char kOdom[] = "odom";
constexpr char kBase[] = "base_footprint";
constexpr char kOptical[] = "stereo_left_optical";
// The drive: along y = kY (left of the centre rail, in front of the drop-off) from kX0 to kX1,
// then standing. The plaza ends at x = 4 (scenes/dataset1_rail_dropoff_ramp.yaml), the lower level
// 0.35 m below it; the camera sees the ground from about 1.1 m ahead of itself.
constexpr double kY = 1.0;
constexpr double kX0 = 0.0;
constexpr double kX1 = 2.6;
constexpr double kStep = 0.1;  // [m] per frame
constexpr int kStandingFrames = 10;
constexpr int kWarmUpFrames = 60;  // at most, at the start, until the first map comes back
constexpr double kEdgeX = 4.0;

// Every raised obstacle point robot.launch's obstacle detector publishes on /obstacles (odom).
class ObstaclePoints {
 public:
  ObstaclePoints(ros::NodeHandle& nh, const std::string& topic) {
    sub_ = nh.subscribe<sensor_msgs::PointCloud2>(
        topic, 50, [this](const sensor_msgs::PointCloud2ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          ++clouds_;
          if (m->header.frame_id != kOdom) ++wrong_frame_;
          if (m->width * m->height == 0) return;
          sensor_msgs::PointCloud2ConstIterator<float> x(*m, "x"), y(*m, "y"), z(*m, "z");
          for (; x != x.end(); ++x, ++y, ++z)
            points_.emplace_back(*x, *y, *z);
        });
  }
  std::vector<Eigen::Vector3f> points() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return points_;
  }
  int clouds() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return clouds_;
  }
  int wrongFrame() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return wrong_frame_;
  }
  void reset() {
    std::lock_guard<std::mutex> lock(mutex_);
    points_.clear();
    clouds_ = 0;
    wrong_frame_ = 0;
  }

 private:
  ros::Subscriber sub_;
  mutable std::mutex mutex_;
  std::vector<Eigen::Vector3f> points_;
  int clouds_ = 0;
  int wrong_frame_ = 0;
};

class RobotLaunch : public ::testing::Test {
 protected:
  // The drive runs once; the tests read what it left.
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    clock_ = new test_util::SteppedClock(*nh_);
    stereo_ = new disparity_test::StereoPublisher(*nh_, "/stereo");
    grid_ = new test_util::Latest<nav_msgs::OccupancyGrid>(*nh_, "/safety_map");
    labels_ = new test_util::Latest<SafetyMapMsg>(*nh_, "/safety_map_labels");
    planes_ = new test_util::Latest<visualization_msgs::MarkerArray>(*nh_, "/planes");
    states_ = new test_util::Latest<GateStateMsg>(*nh_, "/gate_state");
    cmd_pub_ = new ros::Publisher(nh_->advertise<geometry_msgs::Twist>("/cmd_vel_in", 10));
    obstacles_ = new ObstaclePoints(*nh_, "/obstacles");
    drive();
  }
  static void TearDownTestSuite() {
    delete obstacles_;
    delete cmd_pub_;
    delete states_;
    delete planes_;
    delete labels_;
    delete grid_;
    delete stereo_;
    delete clock_;
    delete nh_;
  }

  static void drive() {
    ros::Time t(1000.0);
    clock_->set(t);
    ds::SceneFile sf;
    const std::string path =
        std::string(SSM_SOURCE_DIR) + "/scenes/dataset1_rail_dropoff_ramp.yaml";
    scene_error_ = ds::loadSceneFromFile(path, "", &sf);
    if (!scene_error_.empty()) return;
    const ds::StereoHeadConfig head = sf.camera.scaledTo(320, 240);
    const stereo_safety_map::StereoCameraModel camera = ds::stereoCameraModel(head);
    ds::StereoRenderer renderer(sf.scene, head, sf.seed);

    tf2_ros::TransformBroadcaster tf;
    // The camera's static tf comes from robot.launch (camera_tf:=true, static_tf_publisher, the
    // head's mounting in the .test file's arguments): it must be the renderer's.
    tf2_ros::Buffer buffer;
    tf2_ros::TransformListener listener(buffer);
    if (test_util::waitFor([&] { return buffer.canTransform(kBase, kOptical, ros::Time(0)); },
                           30.0)) {
      const Eigen::Isometry3d T =
          tf2::transformToEigen(buffer.lookupTransform(kBase, kOptical, ros::Time(0)));
      camera_tf_error_ = (T.matrix() - head.baseToLeftOptical().matrix()).cwiseAbs().maxCoeff();
    }
    subscribed_ = stereo_->waitForSubscribers(1, 60.0);
    if (!subscribed_) return;

    cv::Mat left, right;
    // One frame at x: tf odom -> base_footprint and the pair, both stamped t; true when the map
    // of that stamp arrives within wait_s.
    auto frame_at = [&](double x, std::uint64_t frame, double wait_s) {
      Eigen::Isometry3d T_base = Eigen::Isometry3d::Identity();
      T_base.translation() = Eigen::Vector3d(x, kY, 0.0);
      t += ros::Duration(kDt);
      clock_->set(t);
      geometry_msgs::TransformStamped tb = stereo_scene::toMsg(T_base, kOdom, kBase);
      tb.header.stamp = t;
      tf.sendTransform(tb);
      renderer.render(T_base * head.baseToLeftOptical(), frame, &left, &right);
      std_msgs::Header h;
      h.stamp = t;
      h.frame_id = kOptical;
      stereo_->publish(disparity_test::stereoFrame(left, right, camera, h), t);
      return test_util::waitFor(
          [&] {
            auto m = labels_->get();
            return m && m->header.stamp >= t;
          },
          wait_s);
    };
    // The chain is ready when a frame comes back as a map: the disparity nodelet subscribes to
    // the camera as soon as the safety map subscribes to it, but the nodelets' tf listeners may
    // connect to this node's new tf publisher later (under load, after the first frames), and a
    // frame whose odometry they never received is rightly dropped. So the chair stands at the
    // start until one map comes back; only then are frames counted.
    for (int k = 0; k < kWarmUpFrames && ros::ok() && !ready_; ++k) {
      ready_ = frame_at(kX0, static_cast<std::uint64_t>(1000 + k), 1.0);
      ++warm_up_frames_;
    }
    if (!ready_) return;
    obstacles_->reset();  // only the counted frames' obstacles
    const int moving = static_cast<int>((kX1 - kX0) / kStep + 0.5);
    for (int frame = 0; frame <= moving + kStandingFrames && ros::ok(); ++frame) {
      const double x = kX0 + kStep * std::min(frame, moving);
      ++frames_;
      if (frame_at(x, static_cast<std::uint64_t>(frame), kWaitS)) ++maps_;
    }
    last_stamp_ = t;
  }

  static ros::NodeHandle* nh_;
  static test_util::SteppedClock* clock_;
  static disparity_test::StereoPublisher* stereo_;
  static test_util::Latest<nav_msgs::OccupancyGrid>* grid_;
  static test_util::Latest<SafetyMapMsg>* labels_;
  static test_util::Latest<visualization_msgs::MarkerArray>* planes_;
  static test_util::Latest<GateStateMsg>* states_;
  static ros::Publisher* cmd_pub_;
  static ObstaclePoints* obstacles_;
  static std::string scene_error_;
  static double camera_tf_error_;
  static bool subscribed_;
  static bool ready_;
  static int warm_up_frames_;
  static int frames_;
  static int maps_;
  static ros::Time last_stamp_;
};
ros::NodeHandle* RobotLaunch::nh_ = nullptr;
test_util::SteppedClock* RobotLaunch::clock_ = nullptr;
disparity_test::StereoPublisher* RobotLaunch::stereo_ = nullptr;
test_util::Latest<nav_msgs::OccupancyGrid>* RobotLaunch::grid_ = nullptr;
test_util::Latest<SafetyMapMsg>* RobotLaunch::labels_ = nullptr;
test_util::Latest<visualization_msgs::MarkerArray>* RobotLaunch::planes_ = nullptr;
test_util::Latest<GateStateMsg>* RobotLaunch::states_ = nullptr;
ros::Publisher* RobotLaunch::cmd_pub_ = nullptr;
ObstaclePoints* RobotLaunch::obstacles_ = nullptr;
std::string RobotLaunch::scene_error_;
double RobotLaunch::camera_tf_error_ = -1.0;
bool RobotLaunch::subscribed_ = false;
bool RobotLaunch::ready_ = false;
int RobotLaunch::warm_up_frames_ = 0;
int RobotLaunch::frames_ = 0;
int RobotLaunch::maps_ = 0;
ros::Time RobotLaunch::last_stamp_;

TEST_F(RobotLaunch, PublishesTheSafetyMapOfEveryFrameAndGates) {
  ASSERT_EQ(scene_error_, "");
  ASSERT_TRUE(subscribed_) << "robot.launch's disparity nodelet never subscribed to /stereo";
  // camera_tf:=true: static_tf_publisher's transform is the head's mounting.
  EXPECT_GE(camera_tf_error_, 0.0)
      << "no tf base_footprint -> " << kOptical << " from robot.launch";
  EXPECT_LT(camera_tf_error_, 1e-6);
  ASSERT_TRUE(ready_) << "no safety map came back for " << warm_up_frames_
                      << " frames at the start: robot.launch's chain is not wired";
  std::printf("%d warm-up frame(s), then %d frames, %d maps\n", warm_up_frames_, frames_, maps_);
  // Lockstep: each frame waits for its own map, so none may be missing.
  EXPECT_EQ(maps_, frames_) << maps_ << " maps for " << frames_ << " frames";
  auto labels = labels_->get();
  ASSERT_TRUE(labels);
  EXPECT_EQ(labels->header.stamp, last_stamp_);
  EXPECT_EQ(labels->header.frame_id, kOdom);
  nav_msgs::OccupancyGridConstPtr grid;
  ASSERT_TRUE(test_util::waitFor(
      [&] { return (grid = grid_->get()) && grid->header.stamp == last_stamp_; }, kWaitS));
  EXPECT_EQ(grid->header.frame_id, kOdom);
  // The chair's cell (x = kX1, y = kY, on the plaza) is Level: cost 0.
  const int cu =
      static_cast<int>(std::floor((kX1 - grid->info.origin.position.x) / grid->info.resolution));
  const int cv =
      static_cast<int>(std::floor((kY - grid->info.origin.position.y) / grid->info.resolution));
  ASSERT_TRUE(cu >= 0 && cv >= 0 && cu < static_cast<int>(grid->info.width) &&
              cv < static_cast<int>(grid->info.height));
  EXPECT_EQ(grid->data[static_cast<std::size_t>(cv) * grid->info.width + cu], 0);

  // The gate (robot.launch's default gate:=true) decides on a command.
  ASSERT_TRUE(test_util::waitFor([&] { return cmd_pub_->getNumSubscribers() > 0; }, kWaitS))
      << "the gate did not subscribe to /cmd_vel_in";
  const int before = states_->count();
  geometry_msgs::Twist cmd;
  cmd.linear.x = 0.3;
  cmd_pub_->publish(cmd);
  ASSERT_TRUE(test_util::waitFor([&] { return states_->count() > before; }, kWaitS))
      << "no gate_state: the gate is not running or not wired to cmd_vel_in";
  const auto state = states_->get();
  EXPECT_NE(state->reason_code, GateStateMsg::REASON_NO_MAP) << state->reason;
  EXPECT_NE(state->reason_code, GateStateMsg::REASON_NO_TF) << state->reason;
  EXPECT_TRUE(std::isfinite(state->map_age)) << state->reason;
}

TEST_F(RobotLaunch, Dataset1MapHasDropOffEdgesAtThePlazaEdge) {
  ASSERT_EQ(scene_error_, "");
  auto labels = labels_->get();
  ASSERT_TRUE(labels);
  nav_msgs::OccupancyGridConstPtr grid;
  ASSERT_TRUE(test_util::waitFor(
      [&] { return (grid = grid_->get()) && grid->header.stamp == labels->header.stamp; }, kWaitS));
  const nav_msgs::MapMetaData& info = labels->info;
  ASSERT_EQ(grid->info.width, info.width);
  ASSERT_EQ(grid->info.height, info.height);
  ASSERT_EQ(labels->drop_off.size(), grid->data.size());
  int at_edge = 0, elsewhere = 0;
  std::size_t drop_cells = 0;
  for (std::size_t k = 0; k < labels->drop_off.size(); ++k) {
    if (!labels->drop_off[k]) continue;
    ++drop_cells;
    const double x = info.origin.position.x + (k % info.width + 0.5) * info.resolution;
    const double y = info.origin.position.y + (k / info.width + 0.5) * info.resolution;
    // The plaza's edge left of the rail: x = 4, y in (-0.15, 4.2]; a cell or two of stereo noise.
    if (std::abs(x - kEdgeX) <= 0.35 && y > -0.2 && y < 4.3) {
      ++at_edge;
    } else {
      ++elsewhere;
    }
    // Lethal in the OccupancyGrid of the same stamp (cost_drop_off 100).
    EXPECT_EQ(grid->data[k], 100) << "drop-off edge at (" << x << ", " << y << ")";
  }
  std::printf("dataset 1: %zu drop-off edge cells, %d at the plaza's edge, %d elsewhere\n",
              drop_cells, at_edge, elsewhere);
  RecordProperty("drop_off_cells_at_edge", at_edge);
  RecordProperty("drop_off_cells_elsewhere", elsewhere);
  EXPECT_GE(at_edge, 3) << "potential drop-off edges at the plaza's edge (x = 4): " << at_edge
                        << ", elsewhere: " << elsewhere;
  EXPECT_LE(elsewhere, at_edge) << "more drop-off edges away from the drop than at it";

  // rviz: their own marker, one tile per drop-off cell.
  ASSERT_TRUE(test_util::waitFor(
      [&] {
        auto p = planes_->get();
        return p && !p->markers.empty() && p->markers.back().header.stamp == labels->header.stamp;
      },
      kWaitS));
  std::size_t tiles = 0;
  for (const visualization_msgs::Marker& m : planes_->get()->markers) {
    if (m.ns == "drop_off_edges") tiles += m.points.size();
  }
  EXPECT_EQ(tiles, drop_cells);
}

TEST_F(RobotLaunch, ObstacleDetectorMarksTheRailNotTheOpenPlaza) {
  ASSERT_EQ(scene_error_, "");
  ASSERT_TRUE(ready_);
  // The last frame's cloud may still be on its way.
  test_util::waitFor([&] { return obstacles_->clouds() >= frames_; }, kWaitS);
  const std::vector<Eigen::Vector3f> points = obstacles_->points();
  int rail = 0, plaza = 0;
  for (const Eigen::Vector3f& p : points) {
    // The centre rail (scenes/dataset1_rail_dropoff_ramp.yaml): y = -0.15 from x = 3, 0.9 m
    // high on the plaza, then down along the ramp; a voxel of stereo error around it.
    if (p.x() > 2.8 && p.x() < 5.0 && std::abs(p.y() + 0.15) < 0.3 && p.z() > 0.05 &&
        p.z() < 1.05) {
      ++rail;
    }
    // The open plaza between the rail and the bollard / bin on the left (y = 3.2, 3.6), up to
    // its edge: nothing stands there, so every point is the floor's stereo noise.
    if (p.x() > 0.3 && p.x() < kEdgeX - 0.2 && p.y() > 0.3 && p.y() < 2.8) ++plaza;
  }
  std::printf("obstacle cue: %d clouds, %zu raised points, %d on the rail, %d on the open plaza\n",
              obstacles_->clouds(), points.size(), rail, plaza);
  RecordProperty("obstacle_points_rail", rail);
  RecordProperty("obstacle_points_open_plaza", plaza);
  // One cloud per processed frame, also when empty. The detector takes every frame by default
  // (max_rate 0) but lockstep waits for the map only, so frames that arrive while it is busy
  // replace a waiting one.
  EXPECT_GE(obstacles_->clouds(), frames_ / 4);
  EXPECT_EQ(obstacles_->wrongFrame(), 0) << "the cue is in the fixed frame (odom)";
  EXPECT_GE(rail, 50) << "the centre rail in front of the chair is an obstacle";
  EXPECT_LE(plaza, rail / 50) << "the open plaza's floor is no obstacle";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "robot_launch_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
