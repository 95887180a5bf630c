#include "stereo_safety_map/ros/frame_counters.h"

#include <algorithm>

namespace stereo_safety_map {

double FrameCounters::window(const ros::WallTime& now) const {
  return std::max((now - window_start).toSec(), 1e-3);
}

void FrameCounters::addTo(diagnostic_updater::DiagnosticStatusWrapper& stat, double window,
                          const char* dropped_key, bool tf_and_values) const {
  stat.addf("input rate [Hz]", "%.2f", window_received / window);
  stat.addf("processed rate [Hz]", "%.2f", window_processed / window);
  stat.add("frames received", received);
  stat.add("frames processed", processed);
  stat.add(dropped_key, dropped);
  stat.add("frames rejected (bad input)", rejected);
  if (tf_and_values) {
    stat.add("frames dropped (missing tf)", tf_failures);
    stat.add("NaN / inf values skipped", non_finite);
  }
}

void FrameCounters::summarize(diagnostic_updater::DiagnosticStatusWrapper& stat,
                              const ProblemLog& problems, const ros::WallTime& now, double window,
                              const char* slower_because, const std::string& waiting,
                              const std::string& up_to_date) const {
  using diagnostic_msgs::DiagnosticStatus;
  if (problems.recent(now)) {
    stat.summary(DiagnosticStatus::WARN, problems.last());
  } else if (window_dropped > 0) {
    stat.summaryf(DiagnosticStatus::WARN, "dropping frames: %llu of %llu in the last %.1f s (%s)",
                  static_cast<unsigned long long>(window_dropped),
                  static_cast<unsigned long long>(window_received), window, slower_because);
  } else if (received == 0) {
    stat.summary(DiagnosticStatus::OK, waiting);
  } else {
    stat.summary(DiagnosticStatus::OK, up_to_date);
  }
}

void FrameCounters::nextWindow(const ros::WallTime& now, double window) {
  if (window < 1.0) return;
  window_start = now;
  window_received = window_processed = window_dropped = 0;
}

void FrameBooks::countReceived() const {
  std::lock_guard<std::mutex> lock(stats_mutex);
  counts.countReceived();
}

void FrameBooks::reject(const std::string& reason, const std::string& detail) const {
  {
    std::lock_guard<std::mutex> lock(stats_mutex);
    if (reason == "missing tf") {
      ++counts.tf_failures;
    } else {
      ++counts.rejected;
    }
  }
  problems.report(reason, detail);
}

}  // namespace stereo_safety_map
