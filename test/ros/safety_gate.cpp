// The safety-gate nodelet's ROS surface on simulated time, with hand-built safety maps: no map,
// a stale map, a map in another frame, a dead tf and a silent joystick stop the chair and say
// why; a zero command passes at once; a drop-off edge ahead stops it, an open floor lets it go;
// markers; an invalid parameter is refused with its name.
#include "sim_clock.h"
#include "test_util.h"

#include "stereo_safety_map/ros/msgs.h"

#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <set>

using stereo_safety_map::GateStateMsg;
using stereo_safety_map::SafetyMapMsg;
using test_util::Latest;
using test_util::waitFor;

namespace {

constexpr double kWait = 10.0;  // [s] wall

/// A Level map of 8 x 8 m around the origin (0.1 m cells), frame `frame`, stamped `stamp`; cells
/// whose centre x lies in [drop_x, drop_x + 0.1) are drop-off edges, beyond them Unknown.
SafetyMapMsg levelMap(const ros::Time& stamp, const std::string& frame = "odom",
                      double drop_x = 100.0) {
  SafetyMapMsg m;
  m.header.stamp = stamp;
  m.header.frame_id = frame;
  m.info.resolution = 0.1f;
  m.info.width = 81;
  m.info.height = 81;
  m.info.origin.position.x = -4.05;  // corner of cell -40
  m.info.origin.position.y = -4.05;
  m.info.origin.orientation.w = 1.0;
  const std::size_t n = 81 * 81;
  m.labels.assign(n, SafetyMapMsg::LEVEL);
  m.drop_off.assign(n, 0);
  m.segment.assign(n, 0);
  stereo_safety_map::GroundSegment s;
  s.id = 0;
  s.label = SafetyMapMsg::LEVEL;
  s.reachable = true;
  s.plane_valid = true;
  s.normal.z = 1.0;
  m.segments.push_back(s);
  for (int v = 0; v < 81; ++v) {
    for (int u = 0; u < 81; ++u) {
      const double x = (u - 40) * 0.1;
      const std::size_t k = static_cast<std::size_t>(v) * 81 + u;
      if (x >= drop_x - 1e-6 && x < drop_x + 0.1 - 1e-6) m.drop_off[k] = 1;
      if (x >= drop_x + 0.1 - 1e-6) {
        m.labels[k] = SafetyMapMsg::UNKNOWN;
        m.segment[k] = -1;
      }
    }
  }
  return m;
}

class GateRos : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    clock_ = new test_util::SteppedClock(*nh_);
    t_ = ros::Time(500.0);
    clock_->set(t_);
    map_pub_ = new ros::Publisher(nh_->advertise<SafetyMapMsg>("/safety_map_labels", 1, true));
    cmd_pub_ = new ros::Publisher(nh_->advertise<geometry_msgs::Twist>("/cmd_vel_in", 10));
    tf_ = new tf2_ros::TransformBroadcaster;
    state_ = new Latest<GateStateMsg>(*nh_, "/gate_state");
    cmd_out_ = new Latest<geometry_msgs::Twist>(*nh_, "/cmd_vel");
    diagnostics_ = new test_util::DiagnosticsWatcher(*nh_);
  }

  /// Advances the clock by `dt` and publishes the base's tf at the new time (unless `tf` false).
  void advance(double dt, bool tf = true) {
    t_ += ros::Duration(dt);
    clock_->set(t_);
    test_util::sleepFor(0.05);  // the clock reaches the nodelet before what is stamped with it
    if (!tf) return;
    geometry_msgs::TransformStamped b;
    b.header.stamp = t_;
    b.header.frame_id = "odom";
    b.child_frame_id = "base_link";
    b.transform.rotation.w = 1.0;
    tf_->sendTransform(b);
  }

  /// Publishes a command and returns the gate's decision on it (null on timeout).
  boost::shared_ptr<const GateStateMsg> command(double v, double w = 0.0) {
    const int before = state_->count();
    geometry_msgs::Twist c;
    c.linear.x = v;
    c.angular.z = w;
    cmd_pub_->publish(c);
    if (!waitFor([&] { return state_->count() > before; }, kWait)) return nullptr;
    return state_->get();
  }

  void publishMap(const SafetyMapMsg& m) {
    map_pub_->publish(m);
    test_util::sleepFor(0.2);
  }

  static ros::NodeHandle* nh_;
  static test_util::SteppedClock* clock_;
  static ros::Time t_;
  static ros::Publisher* map_pub_;
  static ros::Publisher* cmd_pub_;
  static tf2_ros::TransformBroadcaster* tf_;
  static Latest<GateStateMsg>* state_;
  static Latest<geometry_msgs::Twist>* cmd_out_;
  static test_util::DiagnosticsWatcher* diagnostics_;
};
ros::NodeHandle* GateRos::nh_ = nullptr;
test_util::SteppedClock* GateRos::clock_ = nullptr;
ros::Time GateRos::t_;
ros::Publisher* GateRos::map_pub_ = nullptr;
ros::Publisher* GateRos::cmd_pub_ = nullptr;
tf2_ros::TransformBroadcaster* GateRos::tf_ = nullptr;
Latest<GateStateMsg>* GateRos::state_ = nullptr;
Latest<geometry_msgs::Twist>* GateRos::cmd_out_ = nullptr;
test_util::DiagnosticsWatcher* GateRos::diagnostics_ = nullptr;

// gtest keeps the order of the tests in a file: they build on each other's state.

TEST_F(GateRos, NoMapStopsAndSaysWhy) {
  ASSERT_TRUE(waitFor([&] { return cmd_pub_->getNumSubscribers() > 0; }, 30.0));
  test_util::sleepFor(1.0);
  advance(0.1);
  auto s = command(0.5);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::STOPPED);
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_NO_MAP) << s->reason;
  EXPECT_EQ(s->gated.linear.x, 0.0);
  ASSERT_TRUE(waitFor([&] { return cmd_out_->get() != nullptr; }, kWait));
  EXPECT_EQ(cmd_out_->get()->linear.x, 0.0);
}

TEST_F(GateRos, OpenFloorPassesTheCommandUnchanged) {
  advance(0.1);
  publishMap(levelMap(t_));
  auto s = command(0.5, 0.2);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::ALLOWED) << s->reason;
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_CLEAR);
  EXPECT_EQ(s->gated.linear.x, 0.5);
  EXPECT_EQ(s->gated.angular.z, 0.2);
  EXPECT_EQ(s->commanded.linear.x, 0.5);
  EXPECT_GT(s->stop_distance, 0.0);
  EXPECT_NEAR(s->map_age, 0.0, 1e-6);
  ASSERT_TRUE(waitFor([&] { return cmd_out_->get() && cmd_out_->get()->linear.x == 0.5; }, kWait));
}

TEST_F(GateRos, ZeroCommandPassesAtOnce) {
  auto s = command(0.0);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::ALLOWED);
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_ZERO_COMMAND) << s->reason;
  EXPECT_EQ(s->gated.linear.x, 0.0);
}

TEST_F(GateRos, DropOffEdgeAheadStopsWithTheCell) {
  advance(0.1);
  publishMap(levelMap(t_, "odom", 1.0));  // edge cells at x = 1.0, footprint front at 0.75
  auto s = command(1.0);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::STOPPED) << s->reason;
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_DROP_OFF) << s->reason;
  EXPECT_TRUE(s->hazard);
  EXPECT_TRUE(s->cell_valid);
  EXPECT_TRUE(s->cell_drop_off);
  EXPECT_EQ(s->cell_u, 10);
  EXPECT_NEAR(s->cell_position.x, 1.0, 1e-6);
  EXPECT_EQ(s->gated.linear.x, 0.0);
  // A slow command still fits? No: 0.25 m minus padding is less than 0.2 m of margin plus the
  // reaction. Backing away does.
  s = command(-0.2);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::ALLOWED) << s->reason;
}

TEST_F(GateRos, MarkersShowFootprintStopZoneAndCell) {
  Latest<visualization_msgs::MarkerArray> markers(*nh_, "/gate_markers");
  test_util::sleepFor(0.5);  // the subscription reaches the gate
  auto s = command(1.0);
  ASSERT_TRUE(s);
  ASSERT_TRUE(waitFor([&] { return markers.get() != nullptr; }, kWait));
  std::set<std::string> ns;
  for (const auto& m : markers.get()->markers)
    ns.insert(m.ns);
  EXPECT_TRUE(ns.count("footprint"));
  EXPECT_TRUE(ns.count("stop_zone"));
  EXPECT_TRUE(ns.count("offending_cell"));
}

TEST_F(GateRos, MapInAnotherFrameStops) {
  advance(0.1);
  publishMap(levelMap(t_, "map"));
  auto s = command(0.5);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::STOPPED);
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_WRONG_FRAME) << s->reason;
  EXPECT_NE(s->reason.find("'map'"), std::string::npos) << s->reason;
  EXPECT_EQ(s->gated.linear.x, 0.0);
}

TEST_F(GateRos, StaleMapStops) {
  advance(0.1);
  publishMap(levelMap(t_ - ros::Duration(1.0)));  // max_map_age 0.5 s
  auto s = command(0.5);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::STOPPED);
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_STALE_MAP) << s->reason;
  EXPECT_NEAR(s->map_age, 1.0, 1e-6);
}

TEST_F(GateRos, DeadTfStops) {
  advance(0.1);
  publishMap(levelMap(t_));
  ASSERT_EQ(command(0.5)->state, GateStateMsg::ALLOWED);
  // The clock goes on, the map comes, the odometry does not.
  advance(1.0, false);
  publishMap(levelMap(t_));
  auto s = command(0.5);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, GateStateMsg::STOPPED);
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_NO_TF) << s->reason;
  EXPECT_NE(s->reason.find("dead tf"), std::string::npos) << s->reason;
}

TEST_F(GateRos, StaleMapWhileMovingStopsWithoutANewCommand) {
  advance(0.1);
  publishMap(levelMap(t_));
  ASSERT_EQ(command(0.5)->state, GateStateMsg::ALLOWED);
  advance(0.3);
  ASSERT_EQ(command(0.5)->state, GateStateMsg::ALLOWED);  // map 0.3 s old
  const int before = state_->count();
  advance(0.3);  // map 0.6 s old, last command 0.3 s ago (cmd_timeout 0.5 s): the watchdog
  ASSERT_TRUE(waitFor([&] { return state_->count() > before; }, kWait));
  auto s = state_->get();
  EXPECT_EQ(s->state, GateStateMsg::STOPPED);
  EXPECT_EQ(s->reason_code, GateStateMsg::REASON_STALE_MAP) << s->reason;
  EXPECT_EQ(cmd_out_->get()->linear.x, 0.0);
}

TEST_F(GateRos, SilentJoystickGetsAZeroOnce) {
  advance(0.1);
  publishMap(levelMap(t_));
  ASSERT_EQ(command(0.5)->state, GateStateMsg::ALLOWED);
  ASSERT_TRUE(waitFor([&] { return cmd_out_->get()->linear.x == 0.5; }, kWait));
  const int before = cmd_out_->count();
  advance(0.3);
  publishMap(levelMap(t_));  // the map stays fresh: only the joystick is silent
  advance(0.3);              // 0.6 s without a command (cmd_timeout 0.5 s)
  ASSERT_TRUE(waitFor([&] { return cmd_out_->count() > before; }, kWait));
  EXPECT_EQ(cmd_out_->get()->linear.x, 0.0);
  EXPECT_EQ(state_->get()->reason_code, GateStateMsg::REASON_COMMAND_TIMEOUT)
      << state_->get()->reason;
  // Once: no further zeros while it stays silent.
  const int after = cmd_out_->count();
  advance(0.2);
  test_util::sleepFor(0.5);
  EXPECT_EQ(cmd_out_->count(), after);
}

TEST_F(GateRos, InvalidParameterIsRefusedByName) {
  // /bad_gate in the .test file has deceleration: -1.
  EXPECT_TRUE(waitFor(
      [&] {
        return diagnostics_->seen("bad_gate", diagnostic_msgs::DiagnosticStatus::ERROR,
                                  "deceleration");
      },
      kWait));
  EXPECT_TRUE(diagnostics_->seen("safety_gate", diagnostic_msgs::DiagnosticStatus::OK, "") ||
              diagnostics_->seen("safety_gate", diagnostic_msgs::DiagnosticStatus::WARN, ""));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_gate_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
