// The safety-map nodelet on a known scene: a level floor with a box in front of the robot.
// Checks labels and costs from both inputs (disparity and cloud), the markers, the occupied
// points, the lethal cells of safety_obstacles, the timings, the map's stamp and its staleness,
// ~save (under save_directory only, its PGM equal to the live grid) and ~reset.
#include "test_util.h"

#include "stereo_safety_map/core/map_costs.h"
#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/msgs.h"

#include <gtest/gtest.h>
#include <std_srvs/Empty.h>
#include <visualization_msgs/MarkerArray.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

using stereo_safety_map::SafetyMapMsg;
using stereo_safety_map::StageTimingsMsg;
using test_util::costAt;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kFrames = 16;  // > occ_t / incr_H = 10 frames to make a voxel occupied

// Known by construction (synthetic_scene.h): floor in front of the robot, box at x 2.0..2.6,
// y -0.3..0.3, nothing seen behind the robot, R_max = 4 m.
void expectSceneCosts(const nav_msgs::OccupancyGrid& g, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(g.header.frame_id, "odom");
  EXPECT_NEAR(g.info.resolution, 0.1, 1e-6);
  for (double x : {1.0, 1.3, 1.6}) {
    for (double y : {-0.5, 0.0, 0.5}) {
      EXPECT_EQ(costAt(g, x, y), 0) << "floor (Level) at " << x << ", " << y;
    }
  }
  for (double x : {2.1, 2.3}) {
    for (double y : {-0.2, 0.0, 0.2}) {
      EXPECT_EQ(costAt(g, x, y), 100) << "box (Non-ground) at " << x << ", " << y;
    }
  }
  EXPECT_EQ(costAt(g, -2.0, 0.0), -1) << "behind the robot: Unknown";
  EXPECT_EQ(costAt(g, 4.7, 0.0), -1) << "beyond R_max: Unexamined";
}

void expectSceneLabels(const SafetyMapMsg& m) {
  auto label = [&m](double x, double y) {
    const int k = test_util::cellAt(m.info, x, y);
    return k < 0 ? -1 : static_cast<int>(m.labels[k]);
  };
  EXPECT_EQ(label(1.3, 0.0), SafetyMapMsg::LEVEL);
  EXPECT_EQ(label(2.3, 0.0), SafetyMapMsg::NON_GROUND);
  EXPECT_EQ(label(-2.0, 0.0), SafetyMapMsg::UNKNOWN);
  EXPECT_EQ(label(4.7, 0.0), SafetyMapMsg::UNEXAMINED);
  EXPECT_EQ(m.labels.size(), m.info.width * m.info.height);
  EXPECT_EQ(m.drop_off.size(), m.labels.size());
  ASSERT_GE(m.robot_segment, 0);
  ASSERT_LT(m.robot_segment, static_cast<int>(m.segments.size()));
  const auto& floor = m.segments[m.robot_segment];
  EXPECT_EQ(floor.label, SafetyMapMsg::LEVEL);
  EXPECT_TRUE(floor.plane_valid);
  EXPECT_LT(floor.slope_deg, 1.0);
  EXPECT_NEAR(floor.c, 0.0, 0.03);  // z = a x + b y + c of the floor z = 0
}

class SceneTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    tf_ = new tf2_ros::StaticTransformBroadcaster;
    test_util::publishSceneTf(*tf_);
  }
  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
};
ros::NodeHandle* SceneTest::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* SceneTest::tf_ = nullptr;

TEST_F(SceneTest, DisparityInputLabelsFloorAndBox) {
  test_util::ScenePublisher pub(*nh_, "/disp");
  Latest<nav_msgs::OccupancyGrid> grid(*nh_, "/disp/safety_map");
  Latest<SafetyMapMsg> labels(*nh_, "/disp/safety_map_labels");
  Latest<visualization_msgs::MarkerArray> markers(*nh_, "/disp/planes");
  Latest<sensor_msgs::PointCloud2> points(*nh_, "/disp/occupied_points");
  Latest<StageTimingsMsg> timings(*nh_, "/disp/stage_timings");
  Latest<sensor_msgs::PointCloud2> obstacles(*nh_, "/disp/safety_obstacles");
  ASSERT_TRUE(pub.waitForSubscribers(20.0)) << "the disparity nodelet did not subscribe";
  test_util::sleepFor(0.5);  // let our subscribers connect too

  ros::Time last_stamp;
  for (int i = 0; i < kFrames; ++i) {
    last_stamp = ros::Time::now();
    pub.publishDisparity(last_stamp);
    test_util::sleepFor(0.15);
  }
  ASSERT_TRUE(waitFor(
      [&] {
        auto t = timings.get();
        return t && t->frames_processed >= static_cast<unsigned>(kFrames) - 2;
      },
      20.0))
      << "processed frames: " << (timings.get() ? timings.get()->frames_processed : 0);
  test_util::sleepFor(0.5);

  ASSERT_TRUE(grid.get());
  expectSceneCosts(*grid.get(), "disparity input");
  ASSERT_TRUE(labels.get());
  expectSceneLabels(*labels.get());
  // The map's stamp is the last frame's (its age is visible to a consumer).
  EXPECT_TRUE(waitFor(
      [&] {
        return grid.get()->header.stamp == last_stamp && obstacles.get() &&
               obstacles.get()->header.stamp == last_stamp;
      },
      10.0));
  EXPECT_EQ(grid.get()->header.stamp, last_stamp);
  EXPECT_EQ(labels.get()->header.stamp, last_stamp);

  // safety_obstacles: one point per lethal cell, at its centre, robot base (z 0) + 0.1 m.
  ASSERT_TRUE(obstacles.get());
  const auto& obs = *obstacles.get();
  EXPECT_EQ(obs.header.frame_id, "odom");
  EXPECT_EQ(obs.header.stamp, last_stamp);
  std::size_t lethal = 0;
  for (std::int8_t v : grid.get()->data)
    lethal += v >= 100;
  EXPECT_GT(lethal, 10u);
  EXPECT_EQ(static_cast<std::size_t>(obs.width) * obs.height, lethal);
  bool box_point = false;
  sensor_msgs::PointCloud2ConstIterator<float> ox(obs, "x"), oy(obs, "y"), oz(obs, "z");
  for (std::size_t i = 0; i < static_cast<std::size_t>(obs.width) * obs.height;
       ++i, ++ox, ++oy, ++oz) {
    EXPECT_EQ(costAt(*grid.get(), *ox, *oy), 100) << *ox << ", " << *oy;
    EXPECT_NEAR(*oz, 0.1f, 1e-5);
    box_point = box_point || (std::abs(*ox - 2.3f) < 0.06f && std::abs(*oy) < 0.06f);
  }
  EXPECT_TRUE(box_point) << "no obstacle point on the box";

  // Timings: every stage ran.
  const auto t = timings.get();
  EXPECT_GT(t->total_ms, 0.0);
  EXPECT_GT(t->integrate_ms, 0.0);
  EXPECT_EQ(t->frames_rejected, 0u);

  // Markers: a green Level plane for the floor and grey voxels for the box.
  ASSERT_TRUE(markers.get());
  bool green_plane = false, voxels = false;
  for (const auto& m : markers.get()->markers) {
    if (m.ns == "ground_planes" && m.color.g > 0.7f && m.color.r < 0.3f && !m.points.empty()) {
      green_plane = true;
    }
    if (m.ns == "non_ground_voxels" && !m.points.empty()) voxels = true;
  }
  EXPECT_TRUE(green_plane);
  EXPECT_TRUE(voxels);

  // Occupied points: on the floor (z ~ 0) or on the box (z <= 0.5).
  ASSERT_TRUE(points.get());
  const auto& cloud = *points.get();
  EXPECT_GT(cloud.width * cloud.height, 100u);
  sensor_msgs::PointCloud2ConstIterator<float> z(cloud, "z");
  for (std::size_t i = 0; i < cloud.width * cloud.height; ++i, ++z) {
    ASSERT_GT(*z, -0.06f);
    ASSERT_LT(*z, 0.56f);
  }
}

TEST_F(SceneTest, CloudInputLabelsFloorAndBox) {
  test_util::ScenePublisher pub(*nh_, "/cloud");
  Latest<nav_msgs::OccupancyGrid> grid(*nh_, "/cloud/safety_map");
  Latest<SafetyMapMsg> labels(*nh_, "/cloud/safety_map_labels");
  Latest<StageTimingsMsg> timings(*nh_, "/cloud/stage_timings");
  ASSERT_TRUE(pub.waitForCloudSubscriber(20.0)) << "the cloud nodelet did not subscribe";
  test_util::sleepFor(0.5);
  for (int i = 0; i < kFrames; ++i) {
    pub.publishCloud(ros::Time::now());
    test_util::sleepFor(0.15);
  }
  ASSERT_TRUE(waitFor(
      [&] {
        auto t = timings.get();
        return t && t->frames_processed >= static_cast<unsigned>(kFrames) - 2;
      },
      20.0));
  test_util::sleepFor(0.5);
  ASSERT_TRUE(grid.get());
  expectSceneCosts(*grid.get(), "cloud input");
  ASSERT_TRUE(labels.get());
  expectSceneLabels(*labels.get());
}

// sensor_frame: the same cloud already transformed into another frame (far_away, 50 m from the
// robot, as a cloud in a map frame would be) gives the same map as in the camera's frame. Without
// it the rays would start at far_away's origin: outside the grid, every frame refused.
TEST_F(SceneTest, CloudInAnotherFrameUsesSensorFrame) {
  const Eigen::Isometry3d T_odom_far(Eigen::Translation3d(50.0, 0.0, 0.0));
  geometry_msgs::TransformStamped far = synthetic_scene::toMsg(T_odom_far, "odom", "far_away");
  far.header.stamp = ros::Time::now();
  tf_->sendTransform(far);
  // The scene's cloud (camera frame) in far_away.
  std_msgs::Header h;
  h.frame_id = synthetic_scene::kCameraFrame;
  sensor_msgs::PointCloud2 cloud = synthetic_scene::pointCloud(synthetic_scene::baseToCamera(), h);
  const Eigen::Isometry3f T_far_camera =
      (T_odom_far.inverse() * synthetic_scene::baseToCamera()).cast<float>();
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (std::size_t i = 0; i < cloud.width * cloud.height; ++i, ++x, ++y, ++z) {
    const Eigen::Vector3f p = T_far_camera * Eigen::Vector3f(*x, *y, *z);  // NaN stays NaN
    *x = p.x();
    *y = p.y();
    *z = p.z();
  }
  cloud.header.frame_id = "far_away";

  ros::Publisher pub = nh_->advertise<sensor_msgs::PointCloud2>("/cloud_far/points", 10);
  Latest<nav_msgs::OccupancyGrid> grid(*nh_, "/cloud_far/safety_map");
  Latest<SafetyMapMsg> labels(*nh_, "/cloud_far/safety_map_labels");
  Latest<StageTimingsMsg> timings(*nh_, "/cloud_far/stage_timings");
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() > 0; }, 20.0));
  test_util::sleepFor(0.5);
  for (int i = 0; i < kFrames; ++i) {
    cloud.header.stamp = ros::Time::now();
    pub.publish(cloud);
    test_util::sleepFor(0.15);
  }
  ASSERT_TRUE(waitFor(
      [&] {
        auto t = timings.get();
        return t && t->frames_processed >= static_cast<unsigned>(kFrames) - 2;
      },
      20.0))
      << "frames of a cloud in another frame were not integrated";
  test_util::sleepFor(0.5);
  ASSERT_TRUE(grid.get());
  expectSceneCosts(*grid.get(), "cloud in another frame");
  ASSERT_TRUE(labels.get());
  expectSceneLabels(*labels.get());
}

TEST_F(SceneTest, SaveWritesOctomapAndMapServerFiles) {
  // Runs after DisparityInput... (gtest keeps the order within a file): the map exists. A few
  // more frames keep it live (not stale), then it does not change: the saved PGM must be the
  // published grid, value for value (map_server's raw mode).
  test_util::ScenePublisher pub(*nh_, "/disp");
  Latest<nav_msgs::OccupancyGrid> grid(*nh_, "/disp/safety_map");
  ASSERT_TRUE(pub.waitForSubscribers(10.0));
  for (int i = 0; i < 3; ++i) {
    pub.publishDisparity(ros::Time::now());
    test_util::sleepFor(0.15);
  }
  test_util::sleepFor(0.5);
  // save_directory is /tmp/ssm_scene_test (safety_map_scene.test).
  const std::string dir = "/tmp/ssm_scene_test/" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  stereo_safety_map::SaveMap srv;
  srv.request.path_prefix = dir + "/sub/map";
  ASSERT_TRUE(ros::service::waitForService("/disp/safety_map/save", 10000));
  ASSERT_TRUE(ros::service::call("/disp/safety_map/save", srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  for (const char* ext : {".bt", ".pgm", ".yaml", "_labels.png"}) {
    const std::string f = dir + "/sub/map" + ext;
    EXPECT_TRUE(std::filesystem::exists(f)) << f;
    EXPECT_GT(std::filesystem::file_size(f), 10u) << f;
  }
  for (const auto& e : std::filesystem::directory_iterator(dir + "/sub")) {
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
  }
  std::ifstream yaml(dir + "/sub/map.yaml");
  std::stringstream ss;
  ss << yaml.rdbuf();
  EXPECT_NE(ss.str().find("image: map.pgm"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("resolution: 0.1"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("mode: raw"), std::string::npos) << ss.str();
  std::ifstream bt(dir + "/sub/map.bt");
  std::string first_line;
  std::getline(bt, first_line);
  EXPECT_NE(first_line.find("# Octomap OcTree binary file"), std::string::npos) << first_line;

  // The saved PGM and the live map agree.
  ASSERT_TRUE(grid.get());
  std::ifstream pgm_file(dir + "/sub/map.pgm", std::ios::binary);
  std::stringstream pgm;
  pgm << pgm_file.rdbuf();
  std::vector<std::int8_t> saved;
  int w = 0, h = 0;
  ASSERT_EQ(stereo_safety_map::rawPgmToCosts(pgm.str(), &saved, &w, &h), "");
  EXPECT_EQ(w, static_cast<int>(grid.get()->info.width));
  EXPECT_EQ(h, static_cast<int>(grid.get()->info.height));
  EXPECT_TRUE(saved == grid.get()->data) << "the saved PGM differs from the published grid";
  EXPECT_NE(std::count(saved.begin(), saved.end(), 100), 0);

  // A relative prefix is under save_directory.
  srv = stereo_safety_map::SaveMap();
  srv.request.path_prefix = std::to_string(::getpid()) + "/rel/map";
  ASSERT_TRUE(ros::service::call("/disp/safety_map/save", srv));
  EXPECT_TRUE(srv.response.success) << srv.response.message;
  EXPECT_TRUE(std::filesystem::exists(dir + "/rel/map.pgm"));

  // Leaving save_directory is refused with a message, and nothing is written.
  const std::string outside = "/tmp/ssm_scene_test_outside_" + std::to_string(::getpid());
  std::filesystem::remove_all(outside);
  std::filesystem::create_directories(outside);
  std::filesystem::create_directory_symlink(outside, dir + "/link_out");
  for (const std::string& p :
       {outside + "/map", dir + "/../../etc_map", std::string("../x/map"), dir + "/link_out/map"}) {
    srv = stereo_safety_map::SaveMap();
    srv.request.path_prefix = p;
    ASSERT_TRUE(ros::service::call("/disp/safety_map/save", srv));
    EXPECT_FALSE(srv.response.success) << p;
    EXPECT_NE(srv.response.message.find("outside save_directory"), std::string::npos)
        << p << ": " << srv.response.message;
    EXPECT_TRUE(srv.response.files.empty());
  }
  EXPECT_TRUE(std::filesystem::is_empty(outside));
  EXPECT_FALSE(std::filesystem::exists("/tmp/x/map.pgm"));
  std::filesystem::remove_all(outside);
  std::filesystem::remove_all(dir);
}

TEST_F(SceneTest, StaleMapReadsUnknownAtTheLastFramesStamp) {
  // No frame integrated for stale_input_timeout (2 s, config/safety_map.yaml): the published
  // grid turns all Unknown, still stamped with the last frame; the next frame makes it live.
  test_util::ScenePublisher pub(*nh_, "/disp");
  Latest<nav_msgs::OccupancyGrid> grid(*nh_, "/disp/safety_map");
  Latest<SafetyMapMsg> labels(*nh_, "/disp/safety_map_labels");
  ASSERT_TRUE(pub.waitForSubscribers(10.0));
  ros::Time last;
  for (int i = 0; i < 3; ++i) {
    last = ros::Time::now();
    pub.publishDisparity(last);
    test_util::sleepFor(0.15);
  }
  ASSERT_TRUE(waitFor([&] { return grid.get() && grid.get()->header.stamp == last; }, 5.0));
  const ros::WallTime live_at = ros::WallTime::now();
  EXPECT_EQ(costAt(*grid.get(), 2.3, 0.0), 100);
  auto allUnknown = [&] {
    const auto g = grid.get();
    return g && std::all_of(g->data.begin(), g->data.end(), [](std::int8_t v) { return v == -1; });
  };
  EXPECT_FALSE(allUnknown());
  ASSERT_TRUE(waitFor(allUnknown, 6.0)) << "the map did not go stale";
  const double after = (ros::WallTime::now() - live_at).toSec();
  EXPECT_GT(after, 1.5);  // not before stale_input_timeout (2 s, less the frames' latency)
  EXPECT_LT(after, 3.5);  // checked every 0.25 s
  EXPECT_EQ(grid.get()->header.stamp, last) << "the stale map keeps the last frame's stamp";
  EXPECT_FALSE(grid.get()->data.empty());
  // The labels keep their content and stamp: their consumers (gate, hybrid) check the age.
  ASSERT_TRUE(labels.get());
  EXPECT_EQ(labels.get()->header.stamp, last);

  pub.publishDisparity(ros::Time::now());
  ASSERT_TRUE(waitFor([&] { return !allUnknown(); }, 5.0)) << "a new frame did not revive it";
  EXPECT_EQ(costAt(*grid.get(), 2.3, 0.0), 100);
}

TEST_F(SceneTest, ResetClearsTheMap) {
  test_util::ScenePublisher pub(*nh_, "/disp");
  Latest<nav_msgs::OccupancyGrid> grid(*nh_, "/disp/safety_map");
  ASSERT_TRUE(pub.waitForSubscribers(10.0));
  std_srvs::Empty srv;
  ASSERT_TRUE(ros::service::call("/disp/safety_map/reset", srv));
  test_util::sleepFor(0.3);
  grid.reset();
  // One frame after the reset: no voxel has reached occ_t yet, so the floor is not Level.
  pub.publishDisparity(ros::Time::now());
  ASSERT_TRUE(waitFor([&] { return grid.count() > 0; }, 10.0));
  EXPECT_NE(costAt(*grid.get(), 1.3, 0.0), 0);
  EXPECT_NE(costAt(*grid.get(), 2.3, 0.0), 100);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_scene_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
