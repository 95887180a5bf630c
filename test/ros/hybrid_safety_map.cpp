// The hybrid safety-map nodelet (paper 001, Sec. 2 and 5) on synthetic input whose answer is
// known by construction. A stereo safety map (60 x 60 cells of 0.1 m, x in [-1, 5) m, y in
// [-3, 3) m) holds level floor, a wall at x = 4 m, a table top over x in [2.0, 2.7), y in
// [-0.4, 0.3] (Non-ground, as 000 labels overhangs below robot height), an inclined patch and an
// unknown patch; a laser 0.3 m above the floor at the origin sees the wall and the four table legs
// and passes under the top (the cells behind the legs, in their shadow, stay unknown to it). Also:
// the laser-only fallback, the safety-map nodelet's landmark filter hook, and bad input.
#include "test_util.h"

#include "stereo_safety_map/ros/msgs.h"

#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>

#include <cmath>
#include <limits>

using stereo_safety_map::HybridSafetyMapMsg;
using stereo_safety_map::SafetyMapMsg;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kWarn = diagnostic_msgs::DiagnosticStatus::WARN;
constexpr int kError = diagnostic_msgs::DiagnosticStatus::ERROR;
constexpr double kRes = 0.1;
constexpr int kMinU = -10, kMinV = -30, kW = 60, kH = 60;
constexpr double kWallX = 4.0;
constexpr double kLaserZ = 0.3;
// Table legs (poles of radius 4 cm) at the centres of the top's corner cells.
const double kLegs[4][2] = {{2.0, -0.4}, {2.7, -0.4}, {2.0, 0.3}, {2.7, 0.3}};
constexpr double kLegRadius = 0.04;

bool inTable(int u, int v) {
  return u >= 20 && u <= 27 && v >= -4 && v <= 3;
}

SafetyMapMsg visionMap(const ros::Time& stamp) {
  SafetyMapMsg m;
  m.header.stamp = stamp;
  m.header.frame_id = "odom";
  m.info.resolution = kRes;
  m.info.width = kW;
  m.info.height = kH;
  m.info.origin.position.x = (kMinU - 0.5) * kRes;
  m.info.origin.position.y = (kMinV - 0.5) * kRes;
  m.info.origin.orientation.w = 1.0;
  m.labels.assign(kW * kH, SafetyMapMsg::LEVEL);
  m.drop_off.assign(kW * kH, 0);
  m.segment.assign(kW * kH, -1);
  for (int row = 0; row < kH; ++row) {
    for (int col = 0; col < kW; ++col) {
      const int u = kMinU + col, v = kMinV + row;
      std::uint8_t& l = m.labels[row * kW + col];
      if (u == 40) l = SafetyMapMsg::NON_GROUND;        // the wall
      if (u > 40) l = SafetyMapMsg::UNEXAMINED;         // behind it
      if (inTable(u, v)) l = SafetyMapMsg::NON_GROUND;  // table top and legs
      if (u >= 10 && u < 14 && v >= 10 && v < 14) l = SafetyMapMsg::INCLINED;
      if (u >= 10 && u < 14 && v >= -20 && v < -16) l = SafetyMapMsg::UNKNOWN;
    }
  }
  m.robot_segment = -1;
  return m;
}

// 181 beams over [-90, 90] deg from the laser at the origin: the wall plane x = 4 m and the legs.
sensor_msgs::LaserScan scan(const ros::Time& stamp, const std::string& frame = "laser") {
  sensor_msgs::LaserScan s;
  s.header.stamp = stamp;
  s.header.frame_id = frame;
  s.angle_min = static_cast<float>(-M_PI / 2);
  s.angle_increment = static_cast<float>(M_PI / 180);
  s.angle_max = s.angle_min + 180 * s.angle_increment;
  s.range_min = 0.05f;
  s.range_max = 20.0f;
  for (int i = 0; i <= 180; ++i) {
    const double a = s.angle_min + i * static_cast<double>(s.angle_increment);
    const double dx = std::cos(a), dy = std::sin(a);
    double r = std::numeric_limits<double>::infinity();
    if (dx > 1e-6) r = (kWallX - 0.02) / dx;  // inside the wall cell (x in [3.95, 4.05))
    for (const auto& leg : kLegs) {
      // Ray-circle intersection.
      const double b = dx * leg[0] + dy * leg[1];
      const double c = leg[0] * leg[0] + leg[1] * leg[1] - kLegRadius * kLegRadius;
      const double disc = b * b - c;
      if (disc >= 0.0 && b - std::sqrt(disc) > 0.0) r = std::min(r, b - std::sqrt(disc));
    }
    s.ranges.push_back(r < s.range_max ? static_cast<float>(r)
                                       : std::numeric_limits<float>::infinity());
  }
  return s;
}

int cell(const HybridSafetyMapMsg& m, double x, double y) {
  return test_util::cellAt(m.info, x, y);
}

class HybridTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    tf_ = new tf2_ros::StaticTransformBroadcaster;
    std::vector<geometry_msgs::TransformStamped> ts;
    Eigen::Isometry3d laser = Eigen::Isometry3d::Identity();
    laser.translation().z() = kLaserZ;
    ts.push_back(synthetic_scene::toMsg(Eigen::Isometry3d::Identity(), "odom", "base_link"));
    ts.push_back(synthetic_scene::toMsg(laser, "base_link", "laser"));
    ts.push_back(synthetic_scene::toMsg(synthetic_scene::baseToCamera(), "base_link",
                                        synthetic_scene::kCameraFrame));
    for (auto& t : ts)
      t.header.stamp = ros::Time::now();
    tf_->sendTransform(ts);
    scan_pub_ = new ros::Publisher(nh_->advertise<sensor_msgs::LaserScan>("/scan", 20));
    vision_pub_ = new ros::Publisher(nh_->advertise<SafetyMapMsg>("/safety_map_labels", 5));
    labels_ = new Latest<HybridSafetyMapMsg>(*nh_, "/hybrid_map_labels");
    grid_ = new Latest<nav_msgs::OccupancyGrid>(*nh_, "/hybrid_map");
    laser_grid_ = new Latest<nav_msgs::OccupancyGrid>(*nh_, "/laser_grid");
    laser_only_ = new Latest<HybridSafetyMapMsg>(*nh_, "/laser_only/hybrid_map_labels");
    diagnostics_ = new test_util::DiagnosticsWatcher(*nh_);
    ASSERT_TRUE(waitFor(
        // One manager process: its nodelets share one connection per topic.
        [] { return scan_pub_->getNumSubscribers() >= 1 && vision_pub_->getNumSubscribers() >= 1; },
        20.0));
    test_util::sleepFor(0.5);
    // A few scans, then the stereo map: the published map combines both.
    for (int i = 0; i < 5; ++i) {
      scan_pub_->publish(scan(ros::Time::now()));
      test_util::sleepFor(0.1);
    }
    publishVision();
    ASSERT_TRUE(waitFor([] { return labels_->get() && labels_->get()->vision_used; }, 10.0));
    good_ = labels_->get();
  }

  static void publishVision() { vision_pub_->publish(visionMap(ros::Time::now())); }

  // The classes of the cells known by construction.
  static void expectClasses(const HybridSafetyMapMsg& m) {
    ASSERT_EQ(m.labels.size(), static_cast<std::size_t>(kW * kH));
    ASSERT_EQ(m.vision_labels.size(), m.labels.size());
    ASSERT_EQ(m.laser_states.size(), m.labels.size());
    const int wall = cell(m, kWallX, -1.5);
    const int top = cell(m, 2.4, 0.0);
    const int leg = cell(m, 2.0, -0.4);
    const int incline = cell(m, 1.15, 1.15);
    const int floor = cell(m, 1.0, -1.0);
    const int unknown = cell(m, 1.15, -1.85);
    for (int c : {wall, top, leg, incline, floor, unknown})
      ASSERT_GE(c, 0);
    // Obstacle: seen by the laser and by vision.
    EXPECT_EQ(m.labels[wall], HybridSafetyMapMsg::OBSTACLE);
    EXPECT_EQ(m.laser_states[wall], HybridSafetyMapMsg::LASER_OCCUPIED);
    EXPECT_EQ(m.vision_labels[wall], SafetyMapMsg::NON_GROUND);
    EXPECT_EQ(m.labels[leg], HybridSafetyMapMsg::OBSTACLE);
    // Hazard: vision only, the laser passes under the top (001 Fig. 6).
    EXPECT_EQ(m.labels[top], HybridSafetyMapMsg::HAZARD);
    EXPECT_EQ(m.laser_states[top], HybridSafetyMapMsg::LASER_FREE);
    EXPECT_EQ(m.vision_labels[top], SafetyMapMsg::NON_GROUND);
    // Caution: an incline within the limit.
    EXPECT_EQ(m.labels[incline], HybridSafetyMapMsg::CAUTION);
    // Safe: level floor the laser sees clear.
    EXPECT_EQ(m.labels[floor], HybridSafetyMapMsg::SAFE);
    EXPECT_EQ(m.laser_states[floor], HybridSafetyMapMsg::LASER_FREE);
    // Unknown: vision has no information (the laser cannot see drop-offs).
    EXPECT_EQ(m.labels[unknown], HybridSafetyMapMsg::UNKNOWN);
    EXPECT_EQ(m.laser_states[unknown], HybridSafetyMapMsg::LASER_FREE);
  }

  // Waits until the nodelet has worked off what was sent (no new map for 0.5 s).
  static void waitIdle() {
    int count = -1;
    for (int i = 0; i < 20 && labels_->count() != count; ++i) {
      count = labels_->count();
      test_util::sleepFor(0.5);
    }
  }

  // Publishes bad input, checks the WARN diagnostic, then that a good stereo map still gives the
  // known classes (the laser grid was not corrupted).
  static void checkBad(const std::function<void()>& bad, const std::string& diag_text) {
    diagnostics_->clear();
    for (int i = 0; i < 8; ++i) {
      bad();
      test_util::sleepFor(0.05);
    }
    EXPECT_TRUE(waitFor([&] { return diagnostics_->seen("/hybrid", kWarn, diag_text); }, 8.0))
        << "no WARN diagnostic containing '" << diag_text << "'";
    waitIdle();
    const int before = labels_->count();
    publishVision();
    ASSERT_TRUE(waitFor([&] { return labels_->count() > before; }, 10.0)) << "stopped serving";
    expectClasses(*labels_->get());
  }

  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
  static ros::Publisher* scan_pub_;
  static ros::Publisher* vision_pub_;
  static Latest<HybridSafetyMapMsg>* labels_;
  static Latest<nav_msgs::OccupancyGrid>* grid_;
  static Latest<nav_msgs::OccupancyGrid>* laser_grid_;
  static Latest<HybridSafetyMapMsg>* laser_only_;
  static test_util::DiagnosticsWatcher* diagnostics_;
  static HybridSafetyMapMsg::ConstPtr good_;
};

ros::NodeHandle* HybridTest::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* HybridTest::tf_ = nullptr;
ros::Publisher* HybridTest::scan_pub_ = nullptr;
ros::Publisher* HybridTest::vision_pub_ = nullptr;
Latest<HybridSafetyMapMsg>* HybridTest::labels_ = nullptr;
Latest<nav_msgs::OccupancyGrid>* HybridTest::grid_ = nullptr;
Latest<nav_msgs::OccupancyGrid>* HybridTest::laser_grid_ = nullptr;
Latest<HybridSafetyMapMsg>* HybridTest::laser_only_ = nullptr;
test_util::DiagnosticsWatcher* HybridTest::diagnostics_ = nullptr;
HybridSafetyMapMsg::ConstPtr HybridTest::good_;

TEST_F(HybridTest, MergedMapHasTheHybridClassesOf001) {
  expectClasses(*good_);
  EXPECT_TRUE(good_->vision_used);
  EXPECT_EQ(good_->header.frame_id, "odom");
  // The grid is the stereo map's.
  EXPECT_EQ(good_->info.width, static_cast<unsigned>(kW));
  EXPECT_NEAR(good_->info.origin.position.x, (kMinU - 0.5) * kRes, 1e-6);
}

TEST_F(HybridTest, OccupancyGridFollowsTheValueTable) {
  ASSERT_TRUE(waitFor([] { return grid_->get() != nullptr; }, 5.0));
  const nav_msgs::OccupancyGrid& g = *grid_->get();
  EXPECT_EQ(test_util::costAt(g, kWallX, -1.5), 100);  // Obstacle
  EXPECT_EQ(test_util::costAt(g, 2.4, 0.0), 100);      // Hazard: lethal by default
  EXPECT_EQ(test_util::costAt(g, 1.15, 1.15), 50);     // Caution
  EXPECT_EQ(test_util::costAt(g, 1.0, -1.0), 0);       // Safe
  EXPECT_EQ(test_util::costAt(g, 1.15, -1.85), -1);    // Unknown
}

TEST_F(HybridTest, LaserAloneCallsTheSpaceUnderTheTableFree) {
  // The laser grid (laser-only map): free under the top, where the merged map has a Hazard.
  ASSERT_TRUE(waitFor(
      [] {
        scan_pub_->publish(scan(ros::Time::now()));
        return laser_grid_->get() != nullptr;
      },
      5.0));
  EXPECT_EQ(test_util::costAt(*laser_grid_->get(), 2.4, 0.0), 0);
  EXPECT_EQ(test_util::costAt(*laser_grid_->get(), 2.0, -0.4), 100);
}

TEST_F(HybridTest, WithoutStereoMapsTheLaserPartIsPublished) {
  ASSERT_TRUE(waitFor(
      [] {
        scan_pub_->publish(scan(ros::Time::now()));
        return laser_only_->get() != nullptr;
      },
      10.0));
  const HybridSafetyMapMsg& m = *laser_only_->get();
  EXPECT_FALSE(m.vision_used);
  const int wall = test_util::cellAt(m.info, kWallX, -1.5);
  const int floor = test_util::cellAt(m.info, 1.0, -1.0);
  ASSERT_GE(wall, 0);
  ASSERT_GE(floor, 0);
  EXPECT_EQ(m.labels[wall], HybridSafetyMapMsg::OBSTACLE);
  // The laser sees no ground: free space without vision stays Unknown.
  EXPECT_EQ(m.labels[floor], HybridSafetyMapMsg::UNKNOWN);
  EXPECT_EQ(m.laser_states[floor], HybridSafetyMapMsg::LASER_FREE);
  EXPECT_TRUE(waitFor(
      [] { return diagnostics_->seen("/laser_only/hybrid", kWarn, "laser's part only"); }, 5.0));
}

TEST_F(HybridTest, NanAndInfRangesAreSkipped) {
  checkBad(
      [] {
        sensor_msgs::LaserScan s = scan(ros::Time::now());
        for (std::size_t i = 0; i < s.ranges.size(); ++i) {
          s.ranges[i] = std::numeric_limits<float>::quiet_NaN();
        }
        scan_pub_->publish(s);
      },
      "no usable range");
  // Mixed NaN / +inf / -inf with good ranges: the good ones still count, the others do not
  // clear the wall.
  sensor_msgs::LaserScan s = scan(ros::Time::now());
  for (std::size_t i = 0; i < s.ranges.size(); i += 3) {
    s.ranges[i] = std::numeric_limits<float>::quiet_NaN();
  }
  for (std::size_t i = 1; i < s.ranges.size(); i += 7) {
    s.ranges[i] = -std::numeric_limits<float>::infinity();
  }
  scan_pub_->publish(s);
  test_util::sleepFor(0.3);
  publishVision();
  const int before = labels_->count();
  ASSERT_TRUE(waitFor([&] { return labels_->count() > before; }, 10.0));
  expectClasses(*labels_->get());
}

TEST_F(HybridTest, ScansOfTheWrongSizeAreRefused) {
  checkBad(
      [] {
        sensor_msgs::LaserScan s = scan(ros::Time::now());
        s.ranges.resize(90);  // half the beams the angles promise
        std::fill(s.ranges.begin(), s.ranges.end(), 0.5f);
        scan_pub_->publish(s);
      },
      "ranges, but");
  checkBad(
      [] {
        sensor_msgs::LaserScan s = scan(ros::Time::now());
        s.intensities.assign(3, 1.0f);
        scan_pub_->publish(s);
      },
      "intensities for");
  checkBad(
      [] {
        sensor_msgs::LaserScan s = scan(ros::Time::now());
        s.angle_increment = 0.0f;
        scan_pub_->publish(s);
      },
      "bad angles");
}

TEST_F(HybridTest, ScansWithoutTfAreDropped) {
  checkBad([] { scan_pub_->publish(scan(ros::Time::now(), "nowhere")); }, "no tf to 'odom'");
}

TEST_F(HybridTest, MalformedStereoMapsAreRefused) {
  checkBad(
      [] {
        SafetyMapMsg m = visionMap(ros::Time::now());
        m.labels.resize(10);
        vision_pub_->publish(m);
      },
      "labels has 10 entries");
  checkBad(
      [] {
        SafetyMapMsg m = visionMap(ros::Time::now());
        m.header.frame_id = "map";
        vision_pub_->publish(m);
      },
      "fixed_frame");
  checkBad(
      [] {
        SafetyMapMsg m = visionMap(ros::Time::now());
        m.info.resolution = std::numeric_limits<float>::quiet_NaN();
        vision_pub_->publish(m);
      },
      "resolution");
}

// The safety-map nodelet with ~use_landmark_filter (001 Sec. 4.2 in front of the voxel grid):
// the permanent landmarks come out as a cloud in the fixed frame, and the map built from the
// confirmed points has the scene's labels (floor Level, box Non-ground).
TEST_F(HybridTest, SafetyMapNodeletFiltersThroughLandmarksAndPublishesThem) {
  test_util::ScenePublisher lm(*nh_, "/lm");
  Latest<sensor_msgs::PointCloud2> landmarks(*nh_, "/lm/landmarks");
  Latest<SafetyMapMsg> labels(*nh_, "/lm/safety_map_labels");
  ASSERT_TRUE(lm.waitForSubscribers(20.0));
  test_util::sleepFor(0.5);
  for (int i = 0; i < 12; ++i) {
    lm.publishDisparity(ros::Time::now());
    test_util::sleepFor(0.3);
  }
  ASSERT_TRUE(waitFor([&] { return landmarks.get() && labels.get(); }, 20.0));
  EXPECT_EQ(landmarks.get()->header.frame_id, "odom");
  EXPECT_GT(landmarks.get()->width, 100u);
  const SafetyMapMsg& m = *labels.get();
  const int floor = test_util::cellAt(m.info, 1.3, 0.0);
  const int box = test_util::cellAt(m.info, 2.3, 0.0);
  ASSERT_GE(floor, 0);
  ASSERT_GE(box, 0);
  EXPECT_EQ(m.labels[floor], SafetyMapMsg::LEVEL);
  EXPECT_EQ(m.labels[box], SafetyMapMsg::NON_GROUND);
  EXPECT_TRUE(waitFor(
      [] {
        return diagnostics_->lastValue("/lm/safety_map", "landmark filter (001 Sec. 4.2)") == "on";
      },
      5.0));
}

TEST_F(HybridTest, InvalidConfigurationIsRefused) {
  EXPECT_TRUE(waitFor(
      [] { return diagnostics_->seen("/invalid/hybrid", kError, "min_passage_width"); }, 10.0));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "hybrid_safety_map_test");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}
