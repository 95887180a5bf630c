// The safety-map nodelet's obstacle cue end to end: after the floor has become Level, a cue
// cloud (what ObstacleDetectionNodelet publishes on `obstacles`) on an empty floor cell makes that
// cell Non-ground in the next map; once the cue is older than its lifetime the cell is Level again
// (the voxel grid never saw an obstacle there). The nodelet with the cue off ignores it. A third
// nodelet skips its frames as stationary (000 Sec. IV) once its grid has warmed up: the maps it
// republishes at rest carry the cue all the same, and lose it when it expires.
#include "test_util.h"

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>

using diagnostic_msgs::DiagnosticStatus;
using test_util::costAt;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kFrames = 14;                 // > occ_t / incr_H = 10: the floor becomes Level
constexpr double kCueX = 1.5, kCueY = 0.5;  // an empty floor cell

// A labelled obstacle cloud: a 0.6 m post of points at (x, y) in `frame` (odom = base_link here).
sensor_msgs::PointCloud2 cueCloud(double x, double y, const std::string& frame,
                                  const ros::Time& stamp) {
  sensor_msgs::PointCloud2 c;
  c.header.frame_id = frame;
  c.header.stamp = stamp;
  sensor_msgs::PointCloud2Modifier mod(c);
  mod.setPointCloud2Fields(
      4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "label", 1, sensor_msgs::PointField::UINT32);
  mod.resize(30);
  sensor_msgs::PointCloud2Iterator<float> it(c, "x");
  sensor_msgs::PointCloud2Iterator<std::uint32_t> l(c, "label");
  for (int k = 0; k < 30; ++k, ++it, ++l) {
    it[0] = static_cast<float>(x + 0.01 * (k % 3));
    it[1] = static_cast<float>(y + 0.01 * (k % 2));
    it[2] = static_cast<float>(0.06 + 0.02 * k);
    *l = 1;
  }
  return c;
}

class CueTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    tf_ = new tf2_ros::StaticTransformBroadcaster;
    test_util::publishSceneTf(*tf_);
    diag_ = new test_util::DiagnosticsWatcher(*nh_);
  }
  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
  static test_util::DiagnosticsWatcher* diag_;
};
ros::NodeHandle* CueTest::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* CueTest::tf_ = nullptr;
test_util::DiagnosticsWatcher* CueTest::diag_ = nullptr;

TEST_F(CueTest, CueMarksItsCellsInTheNextMapAndExpires) {
  test_util::ScenePublisher cue_scene(*nh_, "/cue"), nocue_scene(*nh_, "/nocue"),
      rest_scene(*nh_, "/rest");
  Latest<nav_msgs::OccupancyGrid> cue_map(*nh_, "/cue/safety_map");
  Latest<nav_msgs::OccupancyGrid> rest_map(*nh_, "/rest/safety_map");
  ros::Publisher rest_pub = nh_->advertise<sensor_msgs::PointCloud2>("/rest/obstacles", 10);
  Latest<nav_msgs::OccupancyGrid> nocue_map(*nh_, "/nocue/safety_map");
  ros::Publisher cue_pub = nh_->advertise<sensor_msgs::PointCloud2>("/cue/obstacles", 10);
  ros::Publisher nocue_pub = nh_->advertise<sensor_msgs::PointCloud2>("/nocue/obstacles", 10);
  ASSERT_TRUE(cue_scene.waitForSubscribers(20.0));
  ASSERT_TRUE(nocue_scene.waitForSubscribers(20.0));
  ASSERT_TRUE(rest_scene.waitForSubscribers(20.0));
  ASSERT_TRUE(waitFor([&] { return rest_pub.getNumSubscribers() > 0; }, 10.0));
  ASSERT_TRUE(waitFor([&] { return cue_pub.getNumSubscribers() > 0; }, 10.0))
      << "the cue nodelet did not subscribe to obstacles";
  test_util::sleepFor(0.5);

  ros::Time t = ros::Time::now();
  auto frame = [&](double dt) {
    t += ros::Duration(dt);
    cue_scene.publishDisparity(t);
    nocue_scene.publishDisparity(t);
    rest_scene.publishDisparity(t);
  };
  // Waits for the maps of stamp t.
  auto maps = [&] {
    return waitFor(
        [&] {
          auto a = cue_map.get(), b = nocue_map.get(), c = rest_map.get();
          return a && b && c && a->header.stamp == t && b->header.stamp == t &&
                 c->header.stamp == t;
        },
        10.0);
  };
  for (int i = 0; i < kFrames; ++i) {
    frame(0.15);
    ASSERT_TRUE(maps()) << "frame " << i;
  }
  ASSERT_EQ(costAt(*cue_map.get(), kCueX, kCueY), 0) << "the floor is Level";
  ASSERT_EQ(costAt(*nocue_map.get(), kCueX, kCueY), 0);
  ASSERT_EQ(costAt(*cue_map.get(), 2.3, 0.0), 100) << "the box, from the grid";
  ASSERT_EQ(costAt(*rest_map.get(), kCueX, kCueY), 0) << "/rest: the floor is Level";
  ASSERT_EQ(costAt(*rest_map.get(), 2.3, 0.0), 100);
  const std::string skipped = "frames skipped (stationary)";
  ASSERT_TRUE(waitFor([&] { return diag_->lastValue("/rest/safety_map", skipped) == "0"; }, 5.0))
      << "/rest: the warm-up integrates the first frames";

  // A cue at the frame's stamp, then the next frame: Non-ground at once.
  cue_pub.publish(cueCloud(kCueX, kCueY, "odom", t));
  nocue_pub.publish(cueCloud(kCueX, kCueY, "odom", t));
  rest_pub.publish(cueCloud(kCueX, kCueY, "odom", t));
  test_util::sleepFor(0.3);
  frame(0.1);
  ASSERT_TRUE(maps());
  EXPECT_EQ(costAt(*cue_map.get(), kCueX, kCueY), 100);
  EXPECT_EQ(costAt(*nocue_map.get(), kCueX, kCueY), 0) << "cue off: ignored";
  EXPECT_EQ(costAt(*cue_map.get(), kCueX, -kCueY), 0) << "only the cue's cell";
  EXPECT_EQ(costAt(*rest_map.get(), kCueX, kCueY), 100) << "/rest: the cue at rest";
  EXPECT_EQ(costAt(*rest_map.get(), kCueX, -kCueY), 0);
  EXPECT_TRUE(waitFor([&] { return diag_->lastValue("/rest/safety_map", skipped) == "1"; }, 5.0))
      << "/rest: that frame was skipped as stationary, its map recomputed with the cue";
  EXPECT_TRUE(waitFor(
      [&] {
        return diag_->lastValue("/cue/safety_map", "cells made Non-ground by the cue, last map") ==
               "1";
      },
      5.0));

  // Older than the lifetime (0.6 s): the map is the grid's again.
  frame(0.7);
  ASSERT_TRUE(maps());
  EXPECT_EQ(costAt(*cue_map.get(), kCueX, kCueY), 0);
  EXPECT_EQ(costAt(*rest_map.get(), kCueX, kCueY), 0) << "/rest: the expired cue left the map";

  // A cue in another tf frame (base_link, at the origin of odom here) is transformed.
  cue_pub.publish(cueCloud(kCueX, -kCueY, "base_link", t));
  test_util::sleepFor(0.3);
  frame(0.1);
  ASSERT_TRUE(maps());
  EXPECT_EQ(costAt(*cue_map.get(), kCueX, -kCueY), 100);

  // A bad cue (no z field) is reported and ignored; the next map is served.
  sensor_msgs::PointCloud2 bad = cueCloud(1.2, 0.0, "odom", t);
  bad.fields[2].name = "w";
  diag_->clear();
  cue_pub.publish(bad);
  EXPECT_TRUE(waitFor(
      [&] { return diag_->seen("/cue/safety_map", DiagnosticStatus::WARN, "obstacle cue"); },
      10.0));
  frame(0.1);
  ASSERT_TRUE(maps());
  EXPECT_EQ(costAt(*cue_map.get(), 1.2, 0.0), 0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "obstacle_cue_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
