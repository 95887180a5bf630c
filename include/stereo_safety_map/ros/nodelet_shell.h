// The shell every nodelet class (ros/*_ros.h) shares, so that each class keeps only what is its
// own (its configuration, inputs, outputs, core and counters):
// - NodeletShell: the node handles and name, the problem log (problem_log.h), the configuration
//   error (ok() / configError()) and /diagnostics (nodelet_diagnostics.h); refuse() and
//   acceptParams() are the one way a nodelet refuses an invalid configuration or warns about an
//   unknown parameter.
// - FrameNodeletShell<Frame>: for the frame-processing nodelets (disparity, obstacle detection,
//   2D grid, safety map), also the one-slot queue and its worker thread (frame_slot.h) and the
//   frame counters with their books (frame_counters.h), under stats_mutex_.
// - ReconfigureServer<Config>: a dynamic_reconfigure server with the mutex it needs to outlive it.
//
// Destruction stays the nodelet's own business, in its own destructor, in its own order: it stops
// what calls back into it (timers, services, the reconfigure server, its inputs), stopWorker(),
// and diagnostics_->stop(), before its members are destroyed. The shell's destructors stop the
// worker and the diagnostics again, as a net only: by then the nodelet's own members are gone.
#pragma once

#include "stereo_safety_map/ros/frame_counters.h"
#include "stereo_safety_map/ros/frame_slot.h"
#include "stereo_safety_map/ros/nodelet_diagnostics.h"
#include "stereo_safety_map/ros/problem_log.h"

#include <dynamic_reconfigure/server.h>
#include <ros/ros.h>

#include <boost/thread/recursive_mutex.hpp>

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace stereo_safety_map {

class NodeletShell {
 public:
  NodeletShell(const NodeletShell&) = delete;
  NodeletShell& operator=(const NodeletShell&) = delete;

  /// False when the configuration was refused: the nodelet then advertises / subscribes to
  /// nothing and reports configError() as an ERROR diagnostic.
  bool ok() const { return config_error_.empty(); }
  const std::string& configError() const { return config_error_; }

 protected:
  /// The nodelet's name is `pnh`'s namespace.
  NodeletShell(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~NodeletShell();

  /// From now on publishes the status of `task_name` on /diagnostics, filled in by `task`
  /// (nodelet_diagnostics.h). First in the constructor, so that a refusal is reported.
  void startDiagnostics(const std::string& hardware_id, const std::string& task_name,
                        NodeletDiagnostics::Task task, NodeletDiagnostics::Clock clock);
  /// Refuses to start: `error` (naming the parameter and its range) becomes configError(), is
  /// logged as an ERROR and reported on /diagnostics.
  void refuse(const std::string& error);
  /// The parameters as read: with `error` empty, WARNs about every parameter in the private
  /// namespace that is not in `known` (a typo?) and returns true; else refuse(error), false.
  bool acceptParams(const std::string& error, const std::vector<std::string>& known);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  const std::string name_;
  ProblemLog problems_;  ///< refusals by reason, throttled messages, the last problem
  std::string config_error_;
  std::unique_ptr<NodeletDiagnostics> diagnostics_;  ///< from startDiagnostics()
};

template <class Frame>
class FrameNodeletShell : public NodeletShell {
 protected:
  FrameNodeletShell(ros::NodeHandle nh, ros::NodeHandle pnh) : NodeletShell(nh, pnh) {
    counts_.window_start = ros::WallTime::now();
  }
  ~FrameNodeletShell() { stopWorker(); }

  /// Starts the worker thread: process(frame) for every frame taken from the slot, at
  /// max_rate() frames per second at most (0: every frame); a frame whose processing throws is
  /// counted as refused under "exception".
  template <class Process, class MaxRate>
  void startWorker(Process process, MaxRate max_rate) {
    worker_ =
        std::thread([this, process = std::move(process), max_rate = std::move(max_rate)]() mutable {
          slot_.work(process, max_rate, [this](const std::string& what) {
            books_.reject("exception", "frame skipped after an exception: " + what);
          });
        });
  }
  /// Ends the worker for good (the slot refuses frames from now on) and waits for it.
  void stopWorker() {
    slot_.stop();
    if (worker_.joinable()) worker_.join();
  }
  /// Puts `frame` into the slot; true when it replaced a waiting frame, which is counted as
  /// dropped.
  bool putFrame(std::unique_ptr<Frame> frame) {
    if (slot_.put(std::move(frame)) != FrameSlot<Frame>::Put::kReplaced) return false;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.countDropped();
    return true;
  }

  // One-slot queue between the callbacks and the worker.
  FrameSlot<Frame> slot_;  ///< callbacks -> worker (frame_slot.h)
  std::thread worker_;

  // Counters and diagnostics (guarded by stats_mutex_).
  std::mutex stats_mutex_;
  FrameCounters counts_;  ///< frames and the rate window (frame_counters.h)
  FrameBooks books_{stats_mutex_, counts_, problems_};  ///< counts and reports refused frames
};

template <class Config>
class ReconfigureServer {
 public:
  ~ReconfigureServer() { stop(); }

  /// Serves `pnh`'s dynamic_reconfigure parameters: reads the (already validated) start-up values
  /// from the parameter server and calls `callback(config, level)` once with them, then on every
  /// reconfiguration (under the server's mutex).
  template <class Callback>
  void start(const ros::NodeHandle& pnh, Callback callback) {
    server_ = std::make_unique<dynamic_reconfigure::Server<Config>>(mutex_, pnh);
    server_->setCallback(
        [callback](Config& config, std::uint32_t level) mutable { callback(config, level); });
  }
  /// Stops serving (the nodelet's destructor, before what the callback touches is destroyed).
  void stop() { server_.reset(); }

 private:
  boost::recursive_mutex mutex_;  ///< outlives the server that uses it
  std::unique_ptr<dynamic_reconfigure::Server<Config>> server_;
};

}  // namespace stereo_safety_map
