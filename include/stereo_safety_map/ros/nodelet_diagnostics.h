// The /diagnostics of one nodelet: a diagnostic_updater::Updater with the nodelet's one task,
// updated every 0.25 s by a timer. After refuse() (an invalid configuration) the task is no longer
// called and the status is ERROR "invalid configuration: <why>". One copy for every nodelet.
//
// Clock::kWall (disparity, safety map: they must report while a bag is paused): a wall timer; it
// also runs across a ROS clock that goes back, after which diagnostic_updater would wait for its
// next publication time far in the future and publish nothing, so the update is forced then.
// Clock::kRos (the others): a ROS timer, which follows /clock under /use_sim_time.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <functional>
#include <mutex>
#include <string>

namespace stereo_safety_map {

class NodeletDiagnostics {
 public:
  enum class Clock { kRos, kWall };
  using Task = std::function<void(diagnostic_updater::DiagnosticStatusWrapper&)>;

  /// Publishes the status of `task_name` for node `name` (the nodelet's private namespace),
  /// filled in by `task`, from now on.
  NodeletDiagnostics(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& name,
                     const std::string& hardware_id, const std::string& task_name, Task task,
                     Clock clock);
  ~NodeletDiagnostics() { stop(); }

  NodeletDiagnostics(const NodeletDiagnostics&) = delete;
  NodeletDiagnostics& operator=(const NodeletDiagnostics&) = delete;

  /// From now on the status is ERROR "invalid configuration: `error`"; published at once.
  void refuse(const std::string& error);
  /// Stops the timer, waiting for an update in progress: the owner's destructor calls it before
  /// the state the task reads is destroyed.
  void stop();

 private:
  void run(diagnostic_updater::DiagnosticStatusWrapper& stat);

  diagnostic_updater::Updater updater_;
  Task task_;
  std::mutex mutex_;
  std::string config_error_;  ///< (guarded by mutex_)
  ros::Timer timer_;
  ros::WallTimer wall_timer_;
  ros::Time last_update_;  ///< wall timer callback only
};

}  // namespace stereo_safety_map
