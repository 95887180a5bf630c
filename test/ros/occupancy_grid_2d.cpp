// The 2D occupancy-grid nodelet (stereo_safety_map/OccupancyGrid2DNodelet, paper 002) on the
// synthetic scene: level floor, a box at x 2.0..2.6, |y| <= 0.3, 0.5 m high, seen by a camera 1 m
// above the robot's base pitched down 30 deg (test/ros/synthetic_scene.h). Known by
// construction: every image column that sees the box reads its front top edge (the closest point
// in the height band, 002 Sec. 3.3), so the cells at x = 2.0 are raised and the floor between
// the camera and the box is cleared; columns that see only floor have no reading (the floor is
// below the band) and leave their cells unknown.
#include "test_util.h"

#include "stereo_safety_map/ros/occupancy_grid_2d_conversions.h"

#include <gtest/gtest.h>
#include <std_srvs/Empty.h>

#include <cmath>
#include <limits>

using test_util::costAt;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kWarn = diagnostic_msgs::DiagnosticStatus::WARN;
constexpr int kError = diagnostic_msgs::DiagnosticStatus::ERROR;
const char kNode[] = "/occ/occupancy_2d";

class OccupancyGrid2DTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    tf_ = new tf2_ros::StaticTransformBroadcaster;
    test_util::publishSceneTf(*tf_);
    pub_ = new test_util::ScenePublisher(*nh_, "/occ");
    grid_ = new Latest<nav_msgs::OccupancyGrid>(*nh_, "/occ/occupancy_2d");
    diagnostics_ = new test_util::DiagnosticsWatcher(*nh_);
  }

  // The scene's map, known by construction.
 public:
  static void expectSceneGridPublic(const nav_msgs::OccupancyGrid& g) { expectSceneGrid(g); }

 protected:
  static void expectSceneGrid(const nav_msgs::OccupancyGrid& g) {
    EXPECT_EQ(g.header.frame_id, "odom");
    EXPECT_NEAR(g.info.resolution, 0.1, 1e-6);
    // Cells (u, v) centred at (u l, v l): the origin is half a cell off a multiple of l.
    const double ou = g.info.origin.position.x / 0.1 + 0.5;
    EXPECT_NEAR(ou, std::round(ou), 1e-4);
    for (double y : {-0.2, 0.0, 0.2}) {
      EXPECT_EQ(costAt(g, 2.0, y), 100) << "box front at (2.0, " << y << ")";
    }
    for (double x : {1.0, 1.3, 1.6}) {
      EXPECT_EQ(costAt(g, x, 0.0), 0) << "floor between camera and box at (" << x << ", 0)";
    }
    EXPECT_EQ(costAt(g, 3.0, 0.0), -1) << "behind the box: never seen";
    EXPECT_EQ(costAt(g, 1.5, 1.5), -1) << "floor only: no reading, unknown";
    EXPECT_EQ(costAt(g, -2.0, 0.0), -1) << "behind the robot";
    for (std::int8_t v : g.data)
      ASSERT_TRUE(v == 0 || v == 100 || v == -1) << "value outside the table: " << int(v);
  }

  static ros::NodeHandle* nh_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
  static test_util::ScenePublisher* pub_;
  static Latest<nav_msgs::OccupancyGrid>* grid_;
  static test_util::DiagnosticsWatcher* diagnostics_;
};
ros::NodeHandle* OccupancyGrid2DTest::nh_ = nullptr;
tf2_ros::StaticTransformBroadcaster* OccupancyGrid2DTest::tf_ = nullptr;
test_util::ScenePublisher* OccupancyGrid2DTest::pub_ = nullptr;
Latest<nav_msgs::OccupancyGrid>* OccupancyGrid2DTest::grid_ = nullptr;
test_util::DiagnosticsWatcher* OccupancyGrid2DTest::diagnostics_ = nullptr;

TEST(OccupancyGrid2DValueTable, PlanningThresholdsOf002) {
  using stereo_safety_map::occupancyGrid2DValue;
  EXPECT_EQ(occupancyGrid2DValue(0, 50, 150), 0);
  EXPECT_EQ(occupancyGrid2DValue(49, 50, 150), 0);
  EXPECT_EQ(occupancyGrid2DValue(50, 50, 150), -1);
  EXPECT_EQ(occupancyGrid2DValue(128, 50, 150), -1);
  EXPECT_EQ(occupancyGrid2DValue(150, 50, 150), -1);
  EXPECT_EQ(occupancyGrid2DValue(151, 50, 150), 100);
  EXPECT_EQ(occupancyGrid2DValue(255, 50, 150), 100);
  const auto lut = stereo_safety_map::occupancyGrid2DLookup(50, 150);
  for (int g = 0; g < 256; ++g)
    EXPECT_EQ(lut[g], occupancyGrid2DValue(static_cast<std::uint8_t>(g), 50, 150));
}

TEST_F(OccupancyGrid2DTest, BoxOccupiedFloorInFrontFree) {
  ASSERT_TRUE(pub_->waitForSubscribers(20.0)) << "the nodelet did not subscribe";
  test_util::sleepFor(0.5);
  // 002 Sec. 3.4 with K = 20: occupied (> 150) after 2 readings, free (< 50) after 4.
  for (int i = 0; i < 6; ++i) {
    pub_->publishDisparity(ros::Time::now());
    test_util::sleepFor(0.15);
  }
  ASSERT_TRUE(waitFor([] { return grid_->count() >= 5; }, 20.0)) << grid_->count() << " grids";
  test_util::sleepFor(0.5);
  ASSERT_TRUE(grid_->get());
  expectSceneGrid(*grid_->get());
  EXPECT_TRUE(
      waitFor([] { return diagnostics_->lastValue(kNode, "frames processed") == "6"; }, 5.0))
      << diagnostics_->lastValue(kNode, "frames processed");
}

// Publishes `bad` a few times: no grid goes out for it, /diagnostics says why, and a good frame
// afterwards still gives the scene's grid. Runs after BoxOccupiedFloorInFrontFree (gtest keeps
// the order within a file), so the grid exists.
void checkBad(Latest<nav_msgs::OccupancyGrid>& grid, test_util::DiagnosticsWatcher& diagnostics,
              test_util::ScenePublisher& pub, const std::function<void()>& bad,
              const std::string& diag_text, int repeat = 3) {
  // Let the nodelet work off what was sent before.
  int count = -1;
  for (int i = 0; i < 20 && grid.count() != count; ++i) {
    count = grid.count();
    test_util::sleepFor(0.5);
  }
  const int before = grid.count();
  const auto last = grid.get();
  diagnostics.clear();
  for (int i = 0; i < repeat; ++i) {
    bad();
    test_util::sleepFor(0.2);
  }
  EXPECT_TRUE(waitFor([&] { return diagnostics.seen(kNode, kWarn, diag_text); }, 5.0))
      << "no WARN diagnostic containing '" << diag_text << "'";
  test_util::sleepFor(0.3);
  EXPECT_EQ(grid.count(), before) << "a grid was published for bad input";
  EXPECT_EQ(grid.get(), last);
  pub.publishDisparity(ros::Time::now());
  ASSERT_TRUE(waitFor([&] { return grid.count() > before; }, 10.0)) << "nodelet stopped serving";
  SCOPED_TRACE("good frame after bad input '" + diag_text + "'");
  OccupancyGrid2DTest::expectSceneGridPublic(*grid.get());
}

std_msgs::Header header() {
  std_msgs::Header h;
  h.stamp = ros::Time::now();
  h.frame_id = synthetic_scene::kCameraFrame;
  return h;
}

TEST_F(OccupancyGrid2DTest, BadInputIsSkippedAndReported) {
  ASSERT_TRUE(grid_->get()) << "needs the grid of the first test";
  test_util::ScenePublisher& pub = *pub_;
  // Disparity whose size differs from the CameraInfo's.
  checkBad(
      *grid_, *diagnostics_, pub,
      [&] {
        const auto h = header();
        auto l = synthetic_scene::cameraInfo(false, h), r = synthetic_scene::cameraInfo(true, h);
        l.width = r.width = 640;
        l.height = r.height = 480;
        pub.publishDisparity(pub.goodDisparity(), l, r, h.stamp);
      },
      "does not match the left CameraInfo");
  // Unsupported encoding.
  checkBad(
      *grid_, *diagnostics_, pub,
      [&] {
        const auto h = header();
        auto d = pub.goodDisparity();
        d.image.encoding = "16UC1";
        pub.publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                             synthetic_scene::cameraInfo(true, h), h.stamp);
      },
      "unsupported encoding '16UC1'");
  // Zero baseline in the right CameraInfo.
  checkBad(
      *grid_, *diagnostics_, pub,
      [&] {
        const auto h = header();
        auto r = synthetic_scene::cameraInfo(true, h);
        r.P[3] = 0.0;
        pub.publishDisparity(pub.goodDisparity(), synthetic_scene::cameraInfo(false, h), r,
                             h.stamp);
      },
      "zero baseline");
  // Nothing but NaN / inf.
  checkBad(
      *grid_, *diagnostics_, pub,
      [&] {
        const auto h = header();
        auto d = pub.goodDisparity();
        float* px = reinterpret_cast<float*>(d.image.data.data());
        for (std::size_t i = 0; i < d.image.width * d.image.height; ++i) {
          px[i] = (i % 2) ? std::numeric_limits<float>::quiet_NaN()
                          : std::numeric_limits<float>::infinity();
        }
        pub.publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                             synthetic_scene::cameraInfo(true, h), h.stamp);
      },
      "NaN / inf");
  // A frame nobody publishes a transform for: pushed out of the tf filter's queue (5).
  checkBad(
      *grid_, *diagnostics_, pub,
      [&] {
        auto h = header();
        h.frame_id = "no_such_frame";
        auto d = pub.goodDisparity();
        d.header.frame_id = d.image.header.frame_id = h.frame_id;
        pub.publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                             synthetic_scene::cameraInfo(true, h), h.stamp);
      },
      "no tf", 8);
  // Older than the last frame by less than time_jump_reset (5 s): dropped, grid kept.
  const ros::Time last = grid_->get()->header.stamp;
  checkBad(
      *grid_, *diagnostics_, pub, [&] { pub.publishDisparity(last - ros::Duration(1.0)); },
      "out of order");
  EXPECT_NE(diagnostics_->lastValue(kNode, "frames rejected (bad input)"), "0");
}

TEST_F(OccupancyGrid2DTest, ResetClearsTheGrid) {
  std_srvs::Empty srv;
  ASSERT_TRUE(ros::service::waitForService("/occ/occupancy_2d/reset", 10000));
  ASSERT_TRUE(ros::service::call("/occ/occupancy_2d/reset", srv));
  const int before = grid_->count();
  pub_->publishDisparity(ros::Time::now());
  ASSERT_TRUE(waitFor([&] { return grid_->count() > before; }, 10.0));
  // One reading after the reset: +K once (148) is not yet occupied, -K once (108) not yet free.
  EXPECT_EQ(costAt(*grid_->get(), 2.0, 0.0), -1);
  EXPECT_EQ(costAt(*grid_->get(), 1.3, 0.0), -1);
}

TEST_F(OccupancyGrid2DTest, InvalidConfigurationIsRefusedAndReported) {
  EXPECT_TRUE(waitFor(
      [] { return diagnostics_->seen("/bad/occupancy_2d", kError, "must be an integer"); }, 10.0))
      << "no ERROR diagnostic for ~k = 0.5";
  // It subscribes to nothing.
  ros::Publisher p = nh_->advertise<stereo_msgs::DisparityImage>("/bad/stereo/disparity", 1);
  test_util::sleepFor(1.0);
  EXPECT_EQ(p.getNumSubscribers(), 0u);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "occupancy_grid_2d_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
