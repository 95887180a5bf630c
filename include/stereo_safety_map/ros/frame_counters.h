// The frame counts, the rate window and the summary ladder that the frame-processing nodelets
// (disparity, obstacle detection, 2D grid, safety map) report on /diagnostics; one copy instead
// of one per nodelet.
//
// Why not diagnostic_updater's FrequencyStatus / TimeStampStatus: they judge a rate against an
// expected [min, max] that these nodelets do not have (the input rate is the camera's, max_rate
// only caps it), publish other keys ("Actual frequency (Hz)", "Events in window") than the
// README, the rostests and scripts/lib/*.py read ("input rate [Hz]", "frames dropped (...)"), and
// measure on the ROS clock, which under /use_sim_time stops when a bag pauses; these windows are
// on the wall clock, as the nodelets' diagnostics timers are.
//
// Not thread-safe: the owner guards it with its stats mutex, as it does its own counters.
#pragma once

#include "stereo_safety_map/ros/problem_log.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/time.h>

#include <cstdint>
#include <mutex>
#include <string>

namespace stereo_safety_map {

struct FrameCounters {
  std::uint64_t received = 0;
  std::uint64_t processed = 0;
  std::uint64_t dropped = 0;      ///< replaced in the one-slot queue before the worker took them
  std::uint64_t rejected = 0;     ///< bad input (not counting tf failures)
  std::uint64_t tf_failures = 0;  ///< missing tf
  std::uint64_t non_finite = 0;   ///< NaN / inf values (pixels or points) skipped
  double processing_ms_last = 0.0;
  double processing_ms_sum = 0.0;
  // The rate window: since the last diagnostics update that ended it (nextWindow()).
  std::uint64_t window_received = 0;
  std::uint64_t window_processed = 0;
  std::uint64_t window_dropped = 0;
  ros::WallTime window_start;
  ros::WallTime last_received;  ///< when the last frame was received

  void countReceived() {
    ++received;
    ++window_received;
    last_received = ros::WallTime::now();
  }
  void countDropped() {
    ++dropped;
    ++window_dropped;
  }
  void countProcessed(double ms) {
    ++processed;
    ++window_processed;
    processing_ms_last = ms;
    processing_ms_sum += ms;
  }
  double meanProcessingMs() const { return processed > 0 ? processing_ms_sum / processed : 0.0; }

  /// The window's length at `now` [s] (at least 1 ms).
  double window(const ros::WallTime& now) const;
  /// "input rate [Hz]", "processed rate [Hz]" over the window, "frames received", "frames
  /// processed", `dropped_key` (the nodelet's wording: "frames dropped (...)"), "frames rejected
  /// (bad input)"; with `tf_and_values` also "frames dropped (missing tf)" and "NaN / inf values
  /// skipped".
  void addTo(diagnostic_updater::DiagnosticStatusWrapper& stat, double window,
             const char* dropped_key, bool tf_and_values) const;
  /// The summary's common rungs, in order: a recent problem (WARN, the last problem), frames
  /// dropped in the window (WARN "dropping frames: n of m in the last t s (`slower_because`)"),
  /// nothing received yet (OK `waiting`), else OK `up_to_date`.
  void summarize(diagnostic_updater::DiagnosticStatusWrapper& stat, const ProblemLog& problems,
                 const ros::WallTime& now, double window, const char* slower_because,
                 const std::string& waiting, const std::string& up_to_date) const;
  /// Starts a new window at `now` once this one is at least 1 s long (call after the diagnostics
  /// used it).
  void nextWindow(const ros::WallTime& now, double window);
};

/// A frame-processing nodelet's books: its counters (guarded by its stats mutex) and its problem
/// log, for the one way every nodelet counts what it receives and refuses.
struct FrameBooks {
  std::mutex& stats_mutex;
  FrameCounters& counts;
  ProblemLog& problems;

  void countReceived() const;
  /// Counts a refused frame (under "missing tf" in tf_failures, else in rejected) and reports it
  /// under `reason` (a short category), `detail` logged throttled (problem_log.h).
  void reject(const std::string& reason, const std::string& detail) const;
};

}  // namespace stereo_safety_map
