// Closed loop on simulated time: a simulated wheelchair base integrates the gated cmd_vel, the
// ROS-free renderer (dataset/renderer.h) renders the stereo pair at the base's pose each frame,
// and the real disparity, safety-map and safety-gate nodelets (one manager, see the .test file)
// build the map and gate the command. The clock advances in lockstep at 10 Hz: render, publish
// /clock, tf, images and CameraInfo, wait for the safety map of that stamp, publish the command,
// wait for the gate's decision, integrate the base over 0.1 s, advance.
//
// Scenarios (scene files in test/ros/config/gate/, primitives named hazard* are what the chair
// must never overlap, judged with the scene's geometry, not with the map): commanded 1 m/s
// straight from rest, 3.25 m before a 15 cm curb drop, a stair down, a 14 deg ramp up and a pole:
// the chair stops before each; along a corridor with walls 0.5 m beside the footprint and up a
// 5 deg ramp: it reaches the goal. Stop distances (footprint front to hazard) and the slowest
// gated speed go to the test output (RecordProperty) and, with SSM_GATE_OUT=<dir>, to CSV files
// for scripts/demo's plot. The loop is deterministic (lockstep, seeded renderer);
// SSM_GATE_SEED=<n> (image noise) and SSM_GATE_START_OFFSET=<m> (start along x) vary it.
#include "disparity_test_util.h"
#include "sim_clock.h"
#include "test_util.h"

#include "stereo_safety_map/core/safety_gate.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/ros/msgs.h"

#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <thread>

using stereo_safety_map::GateStateMsg;
using stereo_safety_map::SafetyMapMsg;
namespace ds = stereo_safety_map::dataset;
namespace ssm = stereo_safety_map;

namespace {

constexpr double kDt = 0.1;            // [s] frame period of the simulated camera (10 Hz)
constexpr double kCommand = 1.0;       // [m/s] what the joystick asks for
constexpr double kAcceleration = 1.0;  // [m/s^2] of the simulated base
constexpr double kDeceleration = 1.0;  // [m/s^2] its braking: config/safety_gate.yaml's
constexpr double kWheelBase = 0.6;     // [m] between the ground contacts that give the pitch
constexpr double kWaitS = 10.0;        // [s] wall-clock wait for a map or a decision
constexpr char kOdom[] = "odom";
constexpr char kBase[] = "base_link";
constexpr char kOptical[] = "stereo_left_optical";
constexpr double kSceneSpacing = 100.0;  // [m] between the scenarios' places in odom

/// The footprint of config/safety_gate.yaml (x forward, y left).
const std::vector<Eigen::Vector2d> kFootprint = {
    {0.75, 0.35}, {-0.45, 0.35}, {-0.45, -0.35}, {0.75, -0.35}};

/// Every message of a topic, kept in arrival order.
template <typename M>
class Collector {
 public:
  Collector(ros::NodeHandle& nh, const std::string& topic) {
    sub_ = nh.subscribe<M>(topic, 50, [this](const boost::shared_ptr<const M>& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      last_ = m;
      ++count_;
    });
  }
  int count() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return count_;
  }
  boost::shared_ptr<const M> last() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_;
  }

 private:
  ros::Subscriber sub_;
  mutable std::mutex mutex_;
  boost::shared_ptr<const M> last_;
  int count_ = 0;
};

/// The xy outline of a hazard primitive: a convex polygon, or a circle for a vertical cylinder.
struct HazardShape {
  std::string name;
  std::vector<Eigen::Vector2d> polygon;  ///< convex, counter-clockwise
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = -1.0;  ///< >= 0: a circle
};

std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Eigen::Vector2d> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0)
      --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0)
      --k;
    h[k++] = p[i - 1];
  }
  h.resize(k > 0 ? k - 1 : 0);
  return h;
}

std::vector<HazardShape> hazardsOf(const ds::Scene& scene) {
  std::vector<HazardShape> out;
  for (const ds::Primitive& p : scene.primitives) {
    const std::string& tag = p.group.empty() ? p.name : p.group;
    if (tag.rfind("hazard", 0) != 0 && p.name.rfind("hazard", 0) != 0) continue;
    HazardShape h;
    h.name = p.name;
    if (p.shape == ds::Primitive::Shape::kCylinder) {
      h.centre = p.p0.head<2>();
      h.radius = p.radius;
    } else {
      std::vector<Eigen::Vector2d> pts;
      for (const Eigen::Vector3d& v : p.vertices)
        pts.push_back(v.head<2>());
      h.polygon = convexHull(pts);
    }
    out.push_back(h);
  }
  return out;
}

/// Distance from the footprint polygon to a hazard's outline in xy; 0 when they overlap.
double clearance(const std::vector<Eigen::Vector2d>& foot, const HazardShape& h) {
  if (h.radius >= 0.0) {
    const double d = ssm::signedDistanceToPolygon(foot, h.centre) - h.radius;
    return std::max(d, 0.0);
  }
  // Two convex polygons: they overlap when a vertex of one lies in the other or edges cross;
  // otherwise the distance is the smallest vertex-to-polygon distance either way.
  double d = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector2d& p : foot) {
    const double s = ssm::signedDistanceToPolygon(h.polygon, p);
    if (s <= 0.0) return 0.0;
    d = std::min(d, s);
  }
  for (const Eigen::Vector2d& p : h.polygon) {
    const double s = ssm::signedDistanceToPolygon(foot, p);
    if (s <= 0.0) return 0.0;
    d = std::min(d, s);
  }
  return d;  // convex polygons that do not overlap: attained at a vertex
}

struct Result {
  bool moved = false;                                              ///< travelled more than 1 m
  bool stopped = false;                                            ///< stood still at the end
  double travelled = 0.0;                                          ///< [m] along the path
  double min_clearance = std::numeric_limits<double>::infinity();  ///< footprint to hazards
  double final_clearance = std::numeric_limits<double>::infinity();
  std::string nearest_hazard;
  double min_gated_moving = std::numeric_limits<double>::infinity();  ///< once it moved
  int frames = 0;
  int maps_missed = 0;       ///< frames whose map did not come within kWaitS
  int decisions_missed = 0;  ///< commands without a gate decision within kWaitS
  std::string last_reason;
};

class GateClosedLoop : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    clock_ = new test_util::SteppedClock(*nh_);
    clock_->set(ros::Time(1000.0));
    now_ = ros::Time(1000.0);
    stereo_ = new disparity_test::StereoPublisher(*nh_, "/stereo");
    cmd_pub_ = new ros::Publisher(nh_->advertise<geometry_msgs::Twist>("/cmd_vel_in", 10));
    maps_ = new Collector<SafetyMapMsg>(*nh_, "/safety_map_labels");
    states_ = new Collector<GateStateMsg>(*nh_, "/gate_state");
    tf_ = new tf2_ros::TransformBroadcaster;
    static_tf_ = new tf2_ros::StaticTransformBroadcaster;
  }
  static void TearDownTestSuite() {
    delete static_tf_;
    delete tf_;
    delete states_;
    delete maps_;
    delete cmd_pub_;
    delete stereo_;
    delete clock_;
    delete nh_;
  }

  /// Drives `scene_file` at 1 m/s until the chair has stood still for `settle_s` after moving,
  /// or has travelled `goal` metres, or `max_s` of simulated time.
  Result run(const std::string& scene_name, double goal, double max_s, double settle_s, int index);

  static ros::NodeHandle* nh_;
  static test_util::SteppedClock* clock_;
  static ros::Time now_;
  static disparity_test::StereoPublisher* stereo_;
  static ros::Publisher* cmd_pub_;
  static Collector<SafetyMapMsg>* maps_;
  static Collector<GateStateMsg>* states_;
  static tf2_ros::TransformBroadcaster* tf_;
  static tf2_ros::StaticTransformBroadcaster* static_tf_;
};
ros::NodeHandle* GateClosedLoop::nh_ = nullptr;
test_util::SteppedClock* GateClosedLoop::clock_ = nullptr;
ros::Time GateClosedLoop::now_;
disparity_test::StereoPublisher* GateClosedLoop::stereo_ = nullptr;
ros::Publisher* GateClosedLoop::cmd_pub_ = nullptr;
Collector<SafetyMapMsg>* GateClosedLoop::maps_ = nullptr;
Collector<GateStateMsg>* GateClosedLoop::states_ = nullptr;
tf2_ros::TransformBroadcaster* GateClosedLoop::tf_ = nullptr;
tf2_ros::StaticTransformBroadcaster* GateClosedLoop::static_tf_ = nullptr;

Result GateClosedLoop::run(const std::string& scene_name, double goal, double max_s,
                           double settle_s, int index) {
  Result r;
  const std::string path =
      std::string(SSM_SOURCE_DIR) + "/test/ros/config/gate/" + scene_name + ".yaml";
  ds::SceneFile sf;
  const std::string err = ds::loadSceneFromFile(path, "", &sf);
  EXPECT_EQ(err, "") << path;
  if (!err.empty()) return r;
  // Each scenario in a place of its own, so that no map or memory of the last one carries over.
  const Eigen::Vector3d offset(0.0, kSceneSpacing * index, 0.0);
  for (ds::Primitive& p : sf.scene.primitives)
    p.translate(offset);
  const ds::StereoHeadConfig head = sf.camera;
  const ssm::StereoCameraModel camera = ds::stereoCameraModel(head);
  // Robustness runs: another image noise (SSM_GATE_SEED) and start (SSM_GATE_START_OFFSET [m]
  // along x, negative = farther from the hazard); CI runs the scene files as they are.
  const char* seed_env = std::getenv("SSM_GATE_SEED");
  const char* start_env = std::getenv("SSM_GATE_START_OFFSET");
  const std::uint64_t seed = seed_env ? std::strtoull(seed_env, nullptr, 10) : sf.seed;
  ds::StereoRenderer renderer(sf.scene, head, seed);
  const std::vector<HazardShape> hazards = hazardsOf(sf.scene);
  EXPECT_FALSE(hazards.empty() && goal <= 0.0) << scene_name << ": no hazard* primitive";

  // Static tf of the camera; the map starts again.
  std_msgs::Header h;
  h.stamp = now_;
  geometry_msgs::TransformStamped cam =
      stereo_scene::toMsg(head.baseToLeftOptical(), kBase, kOptical);
  cam.header.stamp = now_;
  static_tf_->sendTransform(cam);
  // The first scene may start before the manager has loaded the nodelet (wall-time wait).
  std_srvs::Empty reset;
  if (!ros::service::waitForService("/safety_map/reset", ros::Duration(60.0))) {
    ADD_FAILURE() << "/safety_map/reset never came up";
    return r;
  }
  EXPECT_TRUE(ros::service::call("/safety_map/reset", reset));

  std::ofstream csv;
  if (const char* dir = std::getenv("SSM_GATE_OUT")) {
    csv.open(std::string(dir) + "/" + scene_name + ".csv");
    csv << "t,x,y,z,pitch_deg,v_commanded,v_gated,v_base,state,reason,clearance\n";
  }

  double x = sf.trajectory.start_x + (start_env ? std::atof(start_env) : 0.0);
  double y = sf.trajectory.start_y + offset.y();
  const double yaw = sf.trajectory.start_yaw_deg * M_PI / 180.0;
  const double x0 = x, y0 = y;
  double v = 0.0;  // the base's speed
  double still_since = -1.0;
  cv::Mat left, right;
  const double t_start = now_.toSec();
  for (int frame = 0; frame * kDt <= max_s && ros::ok(); ++frame) {
    // The base's pose: on the ground, pitched with it.
    auto ground = [&](double gx, double gy) {
      double z = 0.0;
      return ds::groundHeightAt(sf.scene, gx, gy, &z) ? z : 0.0;
    };
    const double z = ground(x, y);
    const double zf =
        ground(x + 0.5 * kWheelBase * std::cos(yaw), y + 0.5 * kWheelBase * std::sin(yaw));
    const double zr =
        ground(x - 0.5 * kWheelBase * std::cos(yaw), y - 0.5 * kWheelBase * std::sin(yaw));
    const double pitch = -std::atan2(zf - zr, kWheelBase);  // nose up: negative about +y
    Eigen::Isometry3d T_base = Eigen::Isometry3d::Identity();
    T_base.translation() = Eigen::Vector3d(x, y, z);
    T_base.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                          .toRotationMatrix();

    now_ += ros::Duration(kDt);
    const ros::Time t = now_;
    clock_->set(t);
    geometry_msgs::TransformStamped tb = stereo_scene::toMsg(T_base, kOdom, kBase);
    tb.header.stamp = t;
    tf_->sendTransform(tb);

    renderer.render(T_base * head.baseToLeftOptical(), static_cast<std::uint64_t>(frame), &left,
                    &right);
    h.stamp = t;
    h.frame_id = kOptical;
    stereo_->publish(disparity_test::stereoFrame(left, right, camera, h), t);
    if (!test_util::waitFor(
            [&] {
              auto m = maps_->last();
              return m && m->header.stamp >= t;
            },
            kWaitS)) {
      ++r.maps_missed;
    }

    const int before = states_->count();
    geometry_msgs::Twist cmd;
    cmd.linear.x = kCommand;
    cmd_pub_->publish(cmd);
    double gated = 0.0;
    std::string reason = "no decision";
    int state = GateStateMsg::STOPPED;
    if (test_util::waitFor([&] { return states_->count() > before; }, kWaitS)) {
      auto s = states_->last();
      gated = s->gated.linear.x;
      reason = s->reason;
      state = s->state;
    } else {
      ++r.decisions_missed;  // the base keeps braking: no command is no motion
    }

    // The base: accelerates and brakes towards the gated speed within its limits.
    const double nv = gated > v ? std::min(gated, v + kAcceleration * kDt)
                                : std::max(gated, v - kDeceleration * kDt);
    const double step = 0.5 * (v + nv) * kDt;
    x += step * std::cos(yaw);
    y += step * std::sin(yaw);
    v = nv;
    r.travelled = std::hypot(x - x0, y - y0);
    ++r.frames;
    r.last_reason = reason;
    if (r.travelled > 1.0) r.moved = true;
    if (r.travelled > 0.05) r.min_gated_moving = std::min(r.min_gated_moving, gated);

    // The true footprint against the scene's hazards.
    std::vector<Eigen::Vector2d> foot;
    for (const Eigen::Vector2d& p : kFootprint) {
      foot.emplace_back(x + std::cos(yaw) * p.x() - std::sin(yaw) * p.y(),
                        y + std::sin(yaw) * p.x() + std::cos(yaw) * p.y());
    }
    double c = std::numeric_limits<double>::infinity();
    for (const HazardShape& hz : hazards) {
      const double ch = clearance(foot, hz);
      if (ch < c) {
        c = ch;
        r.nearest_hazard = hz.name;
      }
    }
    r.min_clearance = std::min(r.min_clearance, c);
    r.final_clearance = c;
    if (csv.is_open()) {
      csv << (t.toSec() - t_start) << ',' << x << ',' << (y - offset.y()) << ',' << z << ','
          << pitch * 180.0 / M_PI << ',' << kCommand << ',' << gated << ',' << v << ',' << state
          << ",\"" << reason << "\"," << (std::isfinite(c) ? c : -1.0) << '\n';
    }

    if (goal > 0.0 && r.travelled >= goal) break;
    if (r.moved && v == 0.0 && gated == 0.0) {
      if (still_since < 0.0) still_since = t.toSec();
      if (t.toSec() - still_since >= settle_s) {
        r.stopped = true;
        break;
      }
    } else {
      still_since = -1.0;
    }
  }
  // Let go of the joystick: zero passes at once.
  const int before = states_->count();
  cmd_pub_->publish(geometry_msgs::Twist());
  EXPECT_TRUE(test_util::waitFor([&] { return states_->count() > before; }, kWaitS));
  if (states_->last()) {
    EXPECT_EQ(states_->last()->gated.linear.x, 0.0);
  }
  now_ += ros::Duration(5.0);  // between scenarios
  clock_->set(now_);
  return r;
}

void report(const std::string& name, const Result& r) {
  std::printf(
      "[gate closed loop] %-9s frames %3d travelled %5.2f m, %s, footprint front to "
      "hazard at the end %s m (smallest on the way %s m, %s), slowest gated speed once "
      "moving %.2f m/s, maps missed %d, decisions missed %d; last: %s\n",
      name.c_str(), r.frames, r.travelled, r.stopped ? "stopped" : "not stopped",
      std::isfinite(r.final_clearance) ? std::to_string(r.final_clearance).c_str() : "-",
      std::isfinite(r.min_clearance) ? std::to_string(r.min_clearance).c_str() : "-",
      r.nearest_hazard.c_str(), std::isfinite(r.min_gated_moving) ? r.min_gated_moving : -1.0,
      r.maps_missed, r.decisions_missed, r.last_reason.c_str());
  std::fflush(stdout);
  ::testing::Test::RecordProperty(name + "_travelled_m", std::to_string(r.travelled));
  ::testing::Test::RecordProperty(name + "_clearance_m", std::to_string(r.final_clearance));
  ::testing::Test::RecordProperty(name + "_min_gated_speed", std::to_string(r.min_gated_moving));
  if (const char* dir = std::getenv("SSM_GATE_OUT")) {
    std::ofstream s(std::string(dir) + "/summary.csv", std::ios::app);
    s << name << ',' << r.travelled << ',' << (r.stopped ? 1 : 0) << ',' << r.final_clearance << ','
      << r.min_clearance << ',' << r.min_gated_moving << ',' << r.frames << ",\"" << r.last_reason
      << "\"\n";
  }
}

// The chair starts 3.25 m (footprint front) before the hazard, commanded 1 m/s straight: it
// must drive off (the gate is no wall), stop, and never overlap the hazard.
void expectStopsBefore(const std::string& name, const Result& r) {
  EXPECT_TRUE(r.moved) << name << ": the chair never drove off (" << r.last_reason << ")";
  EXPECT_TRUE(r.stopped) << name << ": the chair did not stop (" << r.last_reason << ")";
  EXPECT_GT(r.min_clearance, 0.0) << name << ": the footprint overlapped " << r.nearest_hazard;
  EXPECT_EQ(r.maps_missed, 0) << name;
  EXPECT_EQ(r.decisions_missed, 0) << name;
}

TEST_F(GateClosedLoop, SubscribedAndRunning) {
  ASSERT_TRUE(stereo_->waitForSubscribers(1, 30.0)) << "the disparity nodelet did not subscribe";
  ASSERT_TRUE(test_util::waitFor([&] { return cmd_pub_->getNumSubscribers() > 0; }, 30.0))
      << "the gate did not subscribe to /cmd_vel_in";
  ASSERT_TRUE(ros::service::waitForService("/safety_map/reset", 30000));
  test_util::sleepFor(1.0);  // our own subscribers
}

TEST_F(GateClosedLoop, StopsBeforeACurbDrop) {
  const Result r = run("curb", 0.0, 12.0, 1.0, 0);
  report("curb", r);
  expectStopsBefore("curb", r);
}

TEST_F(GateClosedLoop, StopsBeforeAStairDown) {
  const Result r = run("stairs", 0.0, 12.0, 1.0, 1);
  report("stairs", r);
  expectStopsBefore("stairs", r);
}

TEST_F(GateClosedLoop, StopsBeforeA14DegreeRamp) {
  const Result r = run("ramp14", 0.0, 12.0, 1.0, 2);
  report("ramp14", r);
  expectStopsBefore("ramp14", r);
}

TEST_F(GateClosedLoop, StopsBeforeAPole) {
  const Result r = run("pole", 0.0, 12.0, 1.0, 3);
  report("pole", r);
  expectStopsBefore("pole", r);
}

TEST_F(GateClosedLoop, DrivesAlongACorridor) {
  const Result r = run("corridor", 4.5, 14.0, 2.0, 4);
  report("corridor", r);
  EXPECT_GE(r.travelled, 4.5) << "stopped in the corridor: " << r.last_reason;
  EXPECT_GT(r.min_clearance, 0.0) << "touched " << r.nearest_hazard;
  EXPECT_EQ(r.maps_missed, 0);
}

TEST_F(GateClosedLoop, DrivesUpA5DegreeRamp) {
  const Result r = run("ramp5", 4.5, 14.0, 2.0, 5);
  report("ramp5", r);
  EXPECT_GE(r.travelled, 4.5) << "stopped on the way up the ramp: " << r.last_reason;
  EXPECT_EQ(r.maps_missed, 0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_gate_closed_loop_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
