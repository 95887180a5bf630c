#include "stereo_safety_map/ros/problem_log.h"

#include <ros/console.h>

#include <sstream>

namespace stereo_safety_map {

void ProblemLog::report(const std::string& reason, const std::string& detail) {
  const ros::WallTime now = ros::WallTime::now();
  bool warn = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counts_[reason];
    last_ = detail;
    last_time_ = now;
    warn = shouldLogLocked(reason, now);
  }
  if (warn) {
    ROS_WARN_STREAM(name_ << ": " << detail);
  } else {
    ROS_DEBUG_STREAM_NAMED("frames", name_ << ": " << reason << ": " << detail);
  }
}

void ProblemLog::note(const std::string& detail) {
  std::lock_guard<std::mutex> lock(mutex_);
  last_ = detail;
  last_time_ = ros::WallTime::now();
}

bool ProblemLog::shouldLog(const std::string& key) {
  std::lock_guard<std::mutex> lock(mutex_);
  return shouldLogLocked(key, ros::WallTime::now());
}

bool ProblemLog::shouldLogLocked(const std::string& key, const ros::WallTime& now) {
  ros::WallTime& last = last_logged_[key];
  if (!last.isZero() && (now - last).toSec() < kLogPeriod) return false;
  last = now;
  return true;
}

void ProblemLog::addTo(diagnostic_updater::DiagnosticStatusWrapper& stat) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& c : counts_)
    stat.add("problem: " + c.first, c.second);
  stat.add("last problem", last_);
}

std::string ProblemLog::last() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_;
}

bool ProblemLog::recent(const ros::WallTime& now) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !last_time_.isZero() && (now - last_time_).toSec() < kProblemRecent;
}

std::string tfFilterFailureMessage(const std::string& what, const std_msgs::Header& header,
                                   const std::string& fixed_frame,
                                   tf2_ros::filter_failure_reasons::FilterFailureReason reason,
                                   const std::string& hint) {
  const char* why = "no transform arrived while it waited in the queue";
  if (reason == tf2_ros::filter_failure_reasons::OutTheBack) {
    why = "the message is older than the transforms tf still holds";
  } else if (reason == tf2_ros::filter_failure_reasons::EmptyFrameID) {
    why = "the message has an empty frame_id";
  }
  std::ostringstream os;
  os << "dropped a " << what << " at t = " << header.stamp << " from '" << header.frame_id
     << "': no tf to '" << fixed_frame << "' (" << why << "). " << hint;
  return os.str();
}

}  // namespace stereo_safety_map
