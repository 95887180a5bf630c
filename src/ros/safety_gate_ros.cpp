#include "stereo_safety_map/ros/safety_gate_ros.h"

#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/safety_map_msg_conversions.h"

#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2/LinearMath/Quaternion.h>
#include <visualization_msgs/MarkerArray.h>

#include <boost/make_shared.hpp>

#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <thread>

namespace stereo_safety_map {

namespace {

constexpr double kWatchdogPeriod = 0.05;  // [s] of ROS time
constexpr double kRateWindow = 2.0;       // [s] wall, for the rates in /diagnostics

bool finite(const geometry_msgs::Twist& t) {
  return std::isfinite(t.linear.x) && std::isfinite(t.linear.y) && std::isfinite(t.linear.z) &&
         std::isfinite(t.angular.x) && std::isfinite(t.angular.y) && std::isfinite(t.angular.z);
}

std_msgs::ColorRGBA stateColour(GateState s, float alpha) {
  switch (s) {
    case GateState::kAllowed:
      return colorMsg(0.1f, 0.8f, 0.1f, alpha);
    case GateState::kSlowed:
      return colorMsg(1.0f, 0.75f, 0.0f, alpha);
    default:
      return colorMsg(0.9f, 0.1f, 0.1f, alpha);
  }
}

}  // namespace

SafetyGateRos::SafetyGateRos(ros::NodeHandle nh, ros::NodeHandle pnh) : NodeletShell(nh, pnh) {
  startDiagnostics(
      "safety gate", "safety gate",
      [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); },
      NodeletDiagnostics::Clock::kRos);
  rate_window_start_ = ros::WallTime::now();

  const std::string err = fromRosParam(pnh_, &ros_config_, &gate_config_);
  if (!acceptParams(err, safetyGateParameterNames())) return;
  gate_ = std::make_unique<SafetyGate>(gate_config_);  // validated: no throw
  SafetyGate::stop(GateReason::kNoMap, "stopped: no safety map received yet", 0.0, 0.0, &decision_);

  tf_buffer_ = std::make_shared<tf2_ros::Buffer>(ros::Duration(10.0));
  tf_listener_ = std::make_shared<tf2_ros::TransformListener>(*tf_buffer_, nh_);
  cmd_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 10);
  state_pub_ = nh_.advertise<GateStateMsg>("gate_state", 10);
  markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("gate_markers", 1);
  const int q = ros_config_.queue_size;
  // TCP_NODELAY: a command or a map must not wait for Nagle's algorithm.
  map_sub_ = nh_.subscribe("safety_map_labels", q, &SafetyGateRos::mapCb, this,
                           ros::TransportHints().tcpNoDelay());
  cmd_sub_ = nh_.subscribe("cmd_vel_in", q, &SafetyGateRos::cmdCb, this,
                           ros::TransportHints().tcpNoDelay());
  watchdog_ = nh_.createTimer(ros::Duration(kWatchdogPeriod), &SafetyGateRos::watchdogCb, this);
  ROS_INFO_STREAM(name_ << ": gating '" << cmd_sub_.getTopic() << "' -> '" << cmd_pub_.getTopic()
                        << "' on '" << map_sub_.getTopic() << "', footprint frame '"
                        << ros_config_.footprint_frame << "' in '" << ros_config_.fixed_frame
                        << "'");
}

SafetyGateRos::~SafetyGateRos() {
  watchdog_.stop();
  diagnostics_->stop();
  cmd_sub_.shutdown();
  map_sub_.shutdown();
}

void SafetyGateRos::mapCb(const SafetyMapMsg::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++maps_received_;
  ++window_maps_;
  if (msg->header.frame_id != ros_config_.fixed_frame) {
    ++maps_rejected_;
    map_problem_ = GateReason::kWrongFrame;
    map_problem_text_ = "stopped: the safety map is in frame '" + msg->header.frame_id +
                        "', the gate works in fixed_frame '" + ros_config_.fixed_frame + "'";
    problems_.report("wrong frame", map_problem_text_);
    map_ = SafetyMap();
    gate_->clearMemory();
    return;
  }
  const std::string err = fromSafetyMapMsg(*msg, &scratch_map_);
  if (!err.empty()) {
    // The previous map stays (and goes stale by itself): one bad message is not a reason to stop.
    ++maps_rejected_;
    problems_.report("bad safety map", "dropped a safety map: " + err);
    if (map_.width <= 0) {
      map_problem_ = GateReason::kInvalidMap;
      map_problem_text_ = "stopped: the safety map could not be read: " + err;
    }
    return;
  }
  std::swap(map_, scratch_map_);
  map_problem_ = GateReason::kClear;
  map_problem_text_.clear();
  map_stamp_ = msg->header.stamp;
  gate_->observe(map_, map_stamp_.toSec());
}

bool SafetyGateRos::footprintPose(const ros::Time& now, Pose2D* pose, double* z, std::string* why) {
  const std::string& fixed = ros_config_.fixed_frame;
  const std::string& foot = ros_config_.footprint_frame;
  std::string tf_error;
  // The latest transform; wait (wall clock) only while there is none at all, e.g. at start.
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(ros_config_.tf_timeout);
  while (!tf_buffer_->canTransform(fixed, foot, ros::Time(0), &tf_error)) {
    if (std::chrono::steady_clock::now() >= deadline || !ros::ok()) {
      *why = "stopped: no tf from '" + fixed + "' to '" + foot + "': " + tf_error;
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  geometry_msgs::TransformStamped t;
  try {
    t = tf_buffer_->lookupTransform(fixed, foot, ros::Time(0));
  } catch (const tf2::TransformException& e) {
    *why = std::string("stopped: tf lookup failed: ") + e.what();
    return false;
  }
  last_tf_age_ = (now - t.header.stamp).toSec();
  if (last_tf_age_ > ros_config_.max_tf_age) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(2) << "stopped: dead tf: the latest transform '" << fixed
       << "' -> '" << foot << "' is " << last_tf_age_ << " s old (max_tf_age "
       << ros_config_.max_tf_age << " s)";
    *why = os.str();
    return false;
  }
  const auto& r = t.transform.rotation;
  const tf2::Quaternion q(r.x, r.y, r.z, r.w);
  if (!(q.length2() > 0.25)) {
    *why = "stopped: the footprint's transform has an invalid rotation";
    return false;
  }
  double roll, pitch, yaw;
  tf2::Matrix3x3(q.normalized()).getRPY(roll, pitch, yaw);
  pose->x = t.transform.translation.x;
  pose->y = t.transform.translation.y;
  pose->yaw = yaw;
  *z = t.transform.translation.z;
  return true;
}

void SafetyGateRos::cmdCb(const geometry_msgs::Twist::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  ++cmds_received_;
  ++window_cmds_;
  last_cmd_ = *msg;
  last_cmd_time_ = now;
  timeout_published_ = false;
  gate(*msg, now);
}

void SafetyGateRos::gate(const geometry_msgs::Twist& cmd, const ros::Time& now) {
  const auto t0 = std::chrono::steady_clock::now();
  const double v = cmd.linear.x, w = cmd.angular.z;
  const double map_age =
      map_.width > 0 ? (now - map_stamp_).toSec() : std::numeric_limits<double>::quiet_NaN();
  last_map_age_ = map_age;
  GateDecision& d = decision_;
  double z = 0.0;
  if (!finite(cmd)) {
    SafetyGate::stop(GateReason::kInvalidCommand, "stopped: the command is not finite", v, w, &d);
    problems_.report("invalid command", "a command on cmd_vel_in is not finite: stopped");
  } else {
    if ((cmd.linear.y != 0.0 || cmd.linear.z != 0.0 || cmd.angular.x != 0.0 ||
         cmd.angular.y != 0.0) &&
        problems_.shouldLog("non-planar command")) {
      // A differential-drive chair: other components are dropped (never added).
      ROS_WARN_STREAM(name_ << ": cmd_vel_in has linear.y / z or angular.x / y; the gate passes "
                               "linear.x and angular.z only (a differential-drive chair)");
    }
    if (map_problem_ != GateReason::kClear || map_.width <= 0) {
      SafetyGate::stop(map_problem_ == GateReason::kClear ? GateReason::kNoMap : map_problem_,
                       map_problem_text_.empty() ? "stopped: no safety map" : map_problem_text_, v,
                       w, &d);
    } else if (v == 0.0 && w == 0.0) {
      // Zero at once: no tf lookup, no sweep; the map's age still decides the state.
      gate_->evaluate(map_, Pose2D{0.0, 0.0, 0.0}, 0.0, 0.0, map_age, &d);
      d.footprint.clear();
    } else {
      Pose2D pose;
      std::string why;
      if (!footprintPose(now, &pose, &z, &why)) {
        SafetyGate::stop(GateReason::kNoTf, why, v, w, &d);
        problems_.report("no tf", why);
      } else {
        gate_->evaluate(map_, pose, v, w, map_age, &d);
        if (d.reason == GateReason::kStaleMap) problems_.report("stale map", d.text);
      }
    }
  }
  gate_ms_last_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  publish(d, now, map_age, z);
}

void SafetyGateRos::watchdogCb(const ros::TimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  if (last_cmd_time_.isZero() || now.isZero()) return;
  if (now < last_cmd_time_) {  // the clock went back (a bag restarted): start over
    last_cmd_time_ = now;
    return;
  }
  const double silence = (now - last_cmd_time_).toSec();
  if (silence > ros_config_.cmd_timeout) {
    if (timeout_published_) return;
    timeout_published_ = true;
    ++timeouts_;
    std::ostringstream os;
    os << std::fixed << std::setprecision(2) << "stopped: no command on cmd_vel_in for " << silence
       << " s (cmd_timeout " << ros_config_.cmd_timeout << " s)";
    SafetyGate::stop(GateReason::kCommandTimeout, os.str(), last_cmd_.linear.x, last_cmd_.angular.z,
                     &decision_);
    if (moving_) problems_.report("command timeout", os.str());
    publish(decision_, now, last_map_age_, 0.0);
    return;
  }
  // A moving command whose map has gone stale (or whose map stopped coming): re-gate it now.
  if (moving_ && map_.width > 0 && (now - map_stamp_).toSec() > gate_config_.max_map_age) {
    gate(last_cmd_, now);
  }
}

void SafetyGateRos::publish(const GateDecision& d, const ros::Time& now, double map_age, double z) {
  geometry_msgs::Twist out;  // everything but linear.x and angular.z stays zero
  out.linear.x = d.v;
  out.angular.z = d.omega;
  cmd_pub_.publish(out);
  moving_ = d.v != 0.0 || d.omega != 0.0;
  switch (d.state) {
    case GateState::kAllowed:
      ++count_allowed_;
      break;
    case GateState::kSlowed:
      ++count_slowed_;
      break;
    case GateState::kStopped:
      ++count_stopped_;
      break;
  }

  auto s = boost::make_shared<GateStateMsg>();
  s->header.stamp = now;
  s->header.frame_id = ros_config_.fixed_frame;
  s->state = static_cast<std::uint8_t>(d.state);
  s->reason_code = static_cast<std::uint8_t>(d.reason);
  s->reason = d.text;
  s->commanded = last_cmd_;
  s->commanded.linear.x = d.commanded_v;
  s->commanded.angular.z = d.commanded_omega;
  s->gated = out;
  s->hazard = d.hazard;
  s->cell_valid = d.cell.valid;
  s->cell_u = d.cell.u;
  s->cell_v = d.cell.v;
  s->cell_position = pointMsg(d.cell.x, d.cell.y, 0.0);
  s->cell_label = static_cast<std::uint8_t>(d.cell.label);
  s->cell_drop_off = d.cell.drop_off;
  s->cell_slope_deg = d.cell.slope_deg;
  s->free_distance = d.free_distance;
  s->free_angle = d.free_angle;
  s->stop_distance = d.stop_distance;
  s->map_age = map_age;
  state_pub_.publish(s);
  if (markers_pub_.getNumSubscribers() > 0) publishMarkers(d, now, z);
}

void SafetyGateRos::publishMarkers(const GateDecision& d, const ros::Time& now, double z) {
  auto arr = boost::make_shared<visualization_msgs::MarkerArray>();
  visualization_msgs::Marker m;
  m.header.frame_id = ros_config_.fixed_frame;
  m.header.stamp = now;
  m.action = visualization_msgs::Marker::DELETEALL;
  arr->markers.push_back(m);  // what the last decision drew goes
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  const double zz = z + 0.03;
  auto outline = [&](const std::string& ns, const std::vector<Eigen::Vector2d>& poly,
                     const std_msgs::ColorRGBA& c, double width) {
    if (poly.size() < 2) return;
    m.ns = ns;
    m.id = 0;
    m.type = visualization_msgs::Marker::LINE_STRIP;
    m.scale.x = width;
    m.color = c;
    m.points.clear();
    for (const Eigen::Vector2d& p : poly)
      m.points.push_back(pointMsg(p.x(), p.y(), zz));
    m.points.push_back(m.points.front());
    arr->markers.push_back(m);
  };
  outline("footprint", d.footprint, stateColour(d.state, 1.0f), 0.04);
  outline("stop_zone", d.stop_zone, stateColour(d.state, 0.6f), 0.015);
  outline("stop_footprint", d.stop_footprint, colorMsg(0.2f, 0.4f, 1.0f, 0.8f), 0.02);
  if (!d.zone_cells.empty()) {
    m.ns = "stop_zone_cells";
    m.id = 0;
    m.type = visualization_msgs::Marker::CUBE_LIST;
    m.scale.x = m.scale.y = 0.09;
    m.scale.z = 0.01;
    m.color = stateColour(d.state, 0.25f);
    m.points.clear();
    for (const Eigen::Vector2d& p : d.zone_cells)
      m.points.push_back(pointMsg(p.x(), p.y(), z + 0.01));
    arr->markers.push_back(m);
  }
  if (d.cell.valid) {
    m.ns = "offending_cell";
    m.id = 0;
    m.type = visualization_msgs::Marker::CUBE;
    m.points.clear();
    m.pose.position = pointMsg(d.cell.x, d.cell.y, z + 0.05);
    m.scale.x = m.scale.y = 0.1;
    m.scale.z = 0.1;
    m.color = colorMsg(1.0f, 0.0f, 0.0f, 0.9f);
    arr->markers.push_back(m);
    m.ns = "reason";
    m.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    m.pose.position.z = z + 0.35;
    m.scale.z = 0.15;
    m.color = colorMsg(1.0f, 1.0f, 1.0f, 1.0f);
    m.text = toString(d.reason);
    arr->markers.push_back(m);
  }
  markers_pub_.publish(arr);
}

void SafetyGateRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  using diagnostic_msgs::DiagnosticStatus;
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::WallTime wall = ros::WallTime::now();
  const double window = (wall - rate_window_start_).toSec();
  if (window >= kRateWindow) {
    cmd_rate_ = window_cmds_ / window;
    map_rate_ = window_maps_ / window;
    window_cmds_ = window_maps_ = 0;
    rate_window_start_ = wall;
  }
  const GateDecision& d = decision_;
  stat.add("state", toString(d.state));
  stat.add("reason", toString(d.reason));
  stat.add("decision", d.text);
  stat.addf("commanded v [m/s], omega [rad/s]", "%.3f, %.3f", d.commanded_v, d.commanded_omega);
  stat.addf("gated v [m/s], omega [rad/s]", "%.3f, %.3f", d.v, d.omega);
  stat.addf("free distance [m]", "%.2f", d.free_distance);
  stat.addf("map age [s]", "%.3f", last_map_age_);
  stat.addf("tf age [s]", "%.3f", last_tf_age_);
  stat.addf("command rate [Hz]", "%.1f", cmd_rate_);
  stat.addf("map rate [Hz]", "%.1f", map_rate_);
  stat.add("commands received", cmds_received_);
  stat.add("maps received", maps_received_);
  stat.add("maps rejected", maps_rejected_);
  stat.add("decisions allowed", count_allowed_);
  stat.add("decisions slowed", count_slowed_);
  stat.add("decisions stopped", count_stopped_);
  stat.add("command timeouts", timeouts_);
  stat.add("cells remembered safe", gate_ ? gate_->rememberedCells() : 0);
  stat.addf("gate time, last [ms]", "%.3f", gate_ms_last_);
  stat.add("fixed frame", ros_config_.fixed_frame);
  stat.add("footprint frame", ros_config_.footprint_frame);
  problems_.addTo(stat);
  if (cmds_received_ == 0) {  // nothing gated yet: say whether the gate could
    if (map_.width > 0 && map_problem_ == GateReason::kClear) {
      stat.summary(DiagnosticStatus::OK,
                   "waiting for commands on cmd_vel_in (safety map received)");
    } else {
      stat.summary(DiagnosticStatus::WARN,
                   "waiting for commands on cmd_vel_in; " + map_problem_text_);
    }
    return;
  }
  switch (d.reason) {
    case GateReason::kNoMap:
    case GateReason::kStaleMap:
    case GateReason::kWrongFrame:
    case GateReason::kInvalidMap:
    case GateReason::kNoTf:
    case GateReason::kInvalidCommand:
    case GateReason::kInvalidPose:
      // The gate cannot judge: the chair is held, and that is a fault of its inputs.
      stat.summary(DiagnosticStatus::WARN, d.text);
      break;
    default:
      stat.summary(DiagnosticStatus::OK, d.text);
  }
}

}  // namespace stereo_safety_map
