// What a nodelet refused and why: a count per reason, the last problem for the diagnostics'
// summary, and log messages throttled per reason. Shared by every nodelet, so that bad input is
// reported the same way everywhere: a WARN at most once per kLogPeriod per reason (a flood of bad
// messages does not flood the log), each further one at debug level under the logger
// ros.stereo_safety_map.frames (for whoever follows the frames one by one).
//
// Thread-safe (its own mutex, never held while logging). A nodelet that also holds its own
// stats mutex in its diagnostics callback takes that one first.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/time.h>
#include <std_msgs/Header.h>
#include <tf2_ros/message_filter.h>

#include <cstdint>
#include <map>
#include <mutex>
#include <string>

namespace stereo_safety_map {

class ProblemLog {
 public:
  static constexpr double kLogPeriod = 5.0;      ///< [s] between two WARNs for the same reason
  static constexpr double kProblemRecent = 5.0;  ///< [s] a problem keeps the diagnostic at WARN

  /// `name` prefixes every message (the nodelet's name).
  explicit ProblemLog(std::string name) : name_(std::move(name)) {}

  /// Counts a problem under `reason` (a short category: "problem: <reason>" in the diagnostics),
  /// keeps `detail` (one line, what was dropped and why) as the last problem, and logs it.
  void report(const std::string& reason, const std::string& detail);

  /// Keeps `detail` as the last problem (the summary shows it for kProblemRecent) without
  /// counting or logging it: for events the caller logs itself, e.g. a map reset.
  void note(const std::string& detail);

  /// Throttle for messages that are not problems of one frame (e.g. frames replaced in the
  /// queue): true at most once per kLogPeriod per `key`.
  bool shouldLog(const std::string& key);

  /// Adds "problem: <reason>" counts and "last problem" to `stat`.
  void addTo(diagnostic_updater::DiagnosticStatusWrapper& stat) const;

  /// The last problem ("" if none).
  std::string last() const;
  /// Whether the last problem is less than kProblemRecent old at `now`.
  bool recent(const ros::WallTime& now) const;

 private:
  bool shouldLogLocked(const std::string& key, const ros::WallTime& now);

  const std::string name_;
  mutable std::mutex mutex_;
  std::map<std::string, std::uint64_t> counts_;       ///< by reason
  std::map<std::string, ros::WallTime> last_logged_;  ///< by reason or key
  std::string last_;
  ros::WallTime last_time_;
};

/// The message for a message a tf2 MessageFilter dropped: "dropped a <what> at t = ... from
/// '<frame>': no tf to '<fixed_frame>' (<why>). <hint>".
std::string tfFilterFailureMessage(const std::string& what, const std_msgs::Header& header,
                                   const std::string& fixed_frame,
                                   tf2_ros::filter_failure_reasons::FilterFailureReason reason,
                                   const std::string& hint = "Is the tf tree complete?");

}  // namespace stereo_safety_map
