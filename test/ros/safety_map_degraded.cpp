// Degraded sensors and time, on simulated time that the test drives (/clock): a robot drives
// over the synthetic scene (test_util.h: floor with a box) while its disparity freezes, goes
// empty, its tf stalls, and its clock jumps back as when a bag is played again.
//
// What must hold: a frozen or empty input and a stalled tf are refused and named in
// /diagnostics; while nothing is used the map ages (max_cell_age = 3 s here): safe cells fall
// back to Unknown, nothing becomes safe, obstacles stay; the map comes back when the input does;
// the clock going back resets the map exactly once, with one warning.
#include "sim_clock.h"
#include "test_util.h"

#include "stereo_safety_map/ros/msgs.h"

#include <gtest/gtest.h>

#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <algorithm>
#include <memory>
#include <string>

using stereo_safety_map::SafetyMapMsg;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr int kWarn = diagnostic_msgs::DiagnosticStatus::WARN;
constexpr char kNode[] = "/deg/safety_map";
constexpr double kStep = 0.05;  // [m] forward per frame: never a stationary frame
constexpr double kFloorY = 0.8;
constexpr long kGapFrames = 15;  // frames sent while odometry is stalled

bool isSafe(std::uint8_t l) {
  return l == SafetyMapMsg::LEVEL || l == SafetyMapMsg::INCLINED;
}

int labelAt(const SafetyMapMsg& m, double x, double y) {
  const int c = test_util::cellAt(m.info, x, y);
  return c < 0 ? -1 : m.labels[c];
}

std::size_t countSafe(const SafetyMapMsg& m) {
  std::size_t n = 0;
  for (auto l : m.labels)
    n += isSafe(l);
  return n;
}

class Degraded : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    clock_ = new test_util::SimClock(*nh_, ros::Time(1000.0));
    static_tf_ = new tf2_ros::StaticTransformBroadcaster;
    tf_ = new tf2_ros::TransformBroadcaster;
    scene_ = new test_util::ScenePublisher(*nh_, "/deg");
    labels_ = new Latest<SafetyMapMsg>(*nh_, "/deg/safety_map_labels");
    diagnostics_ = new test_util::DiagnosticsWatcher(*nh_);
    resets_logged_ = new test_util::RosoutCounter(*nh_, "resetting the map");
    sendStaticTf();
    ASSERT_TRUE(scene_->waitForSubscribers(20.0));
    test_util::sleepFor(0.5);
  }

  static void sendStaticTf() {
    auto t = synthetic_scene::toMsg(synthetic_scene::baseToCamera(), "base_link",
                                    synthetic_scene::kCameraFrame);
    t.header.stamp = clock_->now();
    static_tf_->sendTransform(t);
  }

  enum class Input { kGood, kFrozen, kEmpty, kNoTf };

  // One frame of the robot at x_, stamped with the clock's time; a good frame moves the robot on
  // by kStep (it stands still while its input is degraded, so that it never reaches the box).
  static ros::Time frame(Input input) {
    const ros::Time stamp = clock_->now();
    std_msgs::Header h;
    h.stamp = stamp;
    h.frame_id = synthetic_scene::kCameraFrame;
    Eigen::Isometry3d T_odom_base = Eigen::Isometry3d::Identity();
    // While odometry is stalled the robot creeps on: its frames differ from those around them.
    T_odom_base.translation().x() = input == Input::kNoTf ? x_ + 0.02 : x_;
    if (input != Input::kNoTf) {
      auto t = synthetic_scene::toMsg(T_odom_base, "odom", "base_link");
      t.header.stamp = stamp;
      tf_->sendTransform(t);
    }
    stereo_msgs::DisparityImage d;
    if (input == Input::kFrozen) {
      d = last_disparity_;  // the driver re-sends its last buffer
    } else {
      d = synthetic_scene::disparityImage(T_odom_base * synthetic_scene::baseToCamera(), h);
      if (input == Input::kEmpty) {  // a black camera through stereo_image_proc: all invalid
        float* px = reinterpret_cast<float*>(d.image.data.data());
        for (std::size_t i = 0; i < d.image.width * d.image.height; ++i)
          px[i] = -1.0f;
      } else {
        last_disparity_ = d;
      }
    }
    scene_->publishDisparity(d, synthetic_scene::cameraInfo(false, h),
                             synthetic_scene::cameraInfo(true, h), stamp);
    if (input == Input::kGood) x_ += kStep;
    test_util::sleepFor(0.1);
    return stamp;
  }

  // Good frames until the nodelet has published the map of the last one.
  static ros::Time drive(int n) {
    ros::Time last;
    for (int i = 0; i < n; ++i)
      last = frame(Input::kGood);
    EXPECT_TRUE(
        waitFor([&] { return labels_->get() && labels_->get()->header.stamp == last; }, 20.0))
        << "no map for the frame at " << last;
    return last;
  }

  // A floor cell (floorX(), kFloorY) the camera sees from where the robot is now, out of the
  // box's shadow for every x_ this test reaches.
  static double floorX() { return x_ + 2.0; }

  static std::string value(const std::string& key) { return diagnostics_->lastValue(kNode, key); }
  static long number(const std::string& key) {
    const std::string v = value(key);
    return v.empty() ? -1 : std::stol(v);
  }

  // Every cell of `after` is that of `before`, or was safe and is now Unknown.
  static void expectOnlySafeBecameUnknown(const SafetyMapMsg& before, const SafetyMapMsg& after) {
    ASSERT_EQ(before.info.width, after.info.width);
    ASSERT_EQ(before.info.height, after.info.height);
    ASSERT_EQ(before.info.origin.position.x, after.info.origin.position.x);
    ASSERT_EQ(before.info.origin.position.y, after.info.origin.position.y);
    ASSERT_EQ(before.labels.size(), after.labels.size());
    for (std::size_t k = 0; k < after.labels.size(); ++k) {
      if (after.labels[k] == before.labels[k]) continue;
      EXPECT_TRUE(isSafe(before.labels[k]) && after.labels[k] == SafetyMapMsg::UNKNOWN)
          << "cell " << k << ": " << int(before.labels[k]) << " -> " << int(after.labels[k]);
    }
  }

  // Waits for a map published by the aging timer after `since` with no safe cell left.
  // The aged map is republished at the stamp of the last frame integrated (`stamp`): its age
  // stays visible (README, safety_map topic).
  static SafetyMapMsg::ConstPtr waitForAgedMap(const ros::Time& stamp) {
    SafetyMapMsg::ConstPtr aged;
    waitFor(
        [&] {
          aged = labels_->get();
          return aged && aged->header.stamp == stamp && countSafe(*aged) == 0;
        },
        10.0);
    return aged;
  }

  static ros::NodeHandle* nh_;
  static test_util::SimClock* clock_;
  static tf2_ros::StaticTransformBroadcaster* static_tf_;
  static tf2_ros::TransformBroadcaster* tf_;
  static test_util::ScenePublisher* scene_;
  static Latest<SafetyMapMsg>* labels_;
  static test_util::DiagnosticsWatcher* diagnostics_;
  static test_util::RosoutCounter* resets_logged_;
  static double x_;
  static stereo_msgs::DisparityImage last_disparity_;
};
ros::NodeHandle* Degraded::nh_ = nullptr;
test_util::SimClock* Degraded::clock_ = nullptr;
tf2_ros::StaticTransformBroadcaster* Degraded::static_tf_ = nullptr;
tf2_ros::TransformBroadcaster* Degraded::tf_ = nullptr;
test_util::ScenePublisher* Degraded::scene_ = nullptr;
Latest<SafetyMapMsg>* Degraded::labels_ = nullptr;
test_util::DiagnosticsWatcher* Degraded::diagnostics_ = nullptr;
test_util::RosoutCounter* Degraded::resets_logged_ = nullptr;
double Degraded::x_ = -1.0;
stereo_msgs::DisparityImage Degraded::last_disparity_;

// The tests run in this order and build on each other's state.

TEST_F(Degraded, GoodMapWhileDriving) {
  drive(16);
  const auto m = labels_->get();
  ASSERT_TRUE(m);
  EXPECT_EQ(labelAt(*m, floorX(), kFloorY), SafetyMapMsg::LEVEL);
  EXPECT_EQ(labelAt(*m, 2.3, 0.0), SafetyMapMsg::NON_GROUND);
  EXPECT_EQ(number("map resets"), 0);
}

TEST_F(Degraded, FrozenDisparityIsRefusedAndNamed) {
  const auto before = labels_->get();
  diagnostics_->clear();
  ros::Time first;
  for (int i = 0; i < 4; ++i) {
    const ros::Time t = frame(Input::kFrozen);
    if (i == 0) first = t;
  }
  EXPECT_TRUE(waitFor([] { return diagnostics_->seen(kNode, kWarn, "byte for byte"); }, 5.0));
  EXPECT_TRUE(waitFor([] { return number("problem: frozen input") >= 4; }, 5.0))
      << number("problem: frozen input");
  // No map from the frozen frames.
  EXPECT_EQ(labels_->get(), before);
  // Live again: served.
  drive(3);
  EXPECT_GT(labels_->get()->header.stamp, first);
}

TEST_F(Degraded, EmptyDisparityAgesTheMapIntoUnknownNeverIntoSafe) {
  const auto good = labels_->get();
  ASSERT_TRUE(good);
  ASSERT_GT(countSafe(*good), 100u);
  diagnostics_->clear();
  // A black camera: every pixel invalid, for 2 s (stale_input_timeout is 1 s).
  for (int i = 0; i < 20; ++i)
    frame(Input::kEmpty);
  EXPECT_TRUE(waitFor([] { return diagnostics_->seen(kNode, kWarn, "no frame was used"); }, 5.0));
  EXPECT_TRUE(waitFor([] { return number("problem: no valid data") >= 20; }, 5.0))
      << number("problem: no valid data");
  // Nothing re-observed for more than max_cell_age = 3 s.
  clock_->jump(ros::Duration(4.0));
  const auto aged = waitForAgedMap(good->header.stamp);
  ASSERT_TRUE(aged && aged->header.stamp == good->header.stamp && countSafe(*aged) == 0)
      << "the map was not aged and republished at the last frame's stamp";
  EXPECT_EQ(countSafe(*aged), 0u);
  expectOnlySafeBecameUnknown(*good, *aged);
  EXPECT_EQ(labelAt(*aged, 2.3, 0.0), SafetyMapMsg::NON_GROUND);  // obstacles stay
  EXPECT_TRUE(waitFor([] { return number("cells aged to Unknown (current map)") > 0; }, 5.0));
}

TEST_F(Degraded, TheMapComesBackWithTheInput) {
  drive(6);
  EXPECT_EQ(labelAt(*labels_->get(), floorX(), kFloorY), SafetyMapMsg::LEVEL);
}

TEST_F(Degraded, StalledTfAgesTheMapAndGapFramesAreNotInterpolated) {
  const auto good = labels_->get();
  const auto tfProblems = [] {
    return std::max(0L, number("problem: missing tf")) + std::max(0L, number("problem: stale tf"));
  };
  const long tf_problems_before = tfProblems();
  diagnostics_->clear();
  // Odometry stalls: frames keep coming, without their transform, for 1.5 s; the last ones wait
  // in the tf filter's queue for more than max_tf_wait = 1 s.
  for (int i = 0; i < kGapFrames; ++i)
    frame(Input::kNoTf);
  test_util::sleepFor(1.5);
  EXPECT_TRUE(waitFor([] { return diagnostics_->seen(kNode, kWarn, "no tf"); }, 5.0) ||
              diagnostics_->seen(kNode, kWarn, "no frame was used"));
  EXPECT_TRUE(waitFor([] { return number("problem: missing tf") >= 1; }, 5.0));
  clock_->jump(ros::Duration(4.0));
  const auto aged = waitForAgedMap(good->header.stamp);
  ASSERT_TRUE(aged && aged->header.stamp == good->header.stamp && countSafe(*aged) == 0)
      << "the map was not aged and republished at the last frame's stamp";
  expectOnlySafeBecameUnknown(*good, *aged);
  EXPECT_TRUE(waitFor([] { return diagnostics_->seen(kNode, kWarn, "no frame was used"); }, 5.0));
  // tf is back. The frames still waiting from the gap could now be placed by interpolating
  // across it: they are refused (max_tf_wait = 1 s), and the map comes back from new frames.
  drive(6);
  EXPECT_EQ(labelAt(*labels_->get(), floorX(), kFloorY), SafetyMapMsg::LEVEL);
  // Every frame of the gap is accounted for: dropped by the tf filter (its queue is full) or
  // refused as stale; none was lost without a word, none was placed.
  EXPECT_TRUE(waitFor([] { return number("problem: stale tf") >= 1; }, 5.0));
  EXPECT_TRUE(waitFor([&] { return tfProblems() - tf_problems_before == kGapFrames; }, 5.0))
      << "missing tf " << number("problem: missing tf") << ", stale tf "
      << number("problem: stale tf") << ", of " << kGapFrames << " frames without tf";
}

TEST_F(Degraded, ClockGoingBackResetsTheMapOnceWithOneWarning) {
  EXPECT_EQ(number("map resets"), 0);
  EXPECT_EQ(resets_logged_->count(), 0);
  // A bag played again: the clock and the stamps go back by a minute.
  clock_->jump(ros::Duration(-60.0));
  test_util::sleepFor(0.5);
  sendStaticTf();
  test_util::sleepFor(0.5);
  const ros::Time first = frame(Input::kGood);
  ASSERT_TRUE(
      waitFor([&] { return labels_->get() && labels_->get()->header.stamp == first; }, 20.0));
  // One frame after the reset: nothing is occupied yet, the floor is not Level.
  EXPECT_NE(labelAt(*labels_->get(), floorX() - kStep, kFloorY), SafetyMapMsg::LEVEL);
  drive(15);
  EXPECT_EQ(labelAt(*labels_->get(), floorX(), kFloorY), SafetyMapMsg::LEVEL);
  EXPECT_TRUE(waitFor([] { return number("map resets") == 1; }, 5.0)) << value("map resets");
  test_util::sleepFor(1.0);
  EXPECT_EQ(number("map resets"), 1);
  EXPECT_EQ(resets_logged_->count(), 1);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_degraded_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
