#include "stereo_safety_map/ros/nodelet_diagnostics.h"

#include <utility>

namespace stereo_safety_map {

NodeletDiagnostics::NodeletDiagnostics(ros::NodeHandle nh, ros::NodeHandle pnh,
                                       const std::string& name, const std::string& hardware_id,
                                       const std::string& task_name, Task task, Clock clock)
    : updater_(nh, pnh, name), task_(std::move(task)) {
  updater_.setHardwareID(hardware_id);
  updater_.add(task_name, this, &NodeletDiagnostics::run);
  if (clock == Clock::kWall) {
    wall_timer_ = nh.createWallTimer(ros::WallDuration(0.25), [this](const ros::WallTimerEvent&) {
      const ros::Time now = ros::Time::now();
      if (now < last_update_) {
        updater_.force_update();
      } else {
        updater_.update();
      }
      last_update_ = now;
    });
  } else {
    timer_ =
        nh.createTimer(ros::Duration(0.25), [this](const ros::TimerEvent&) { updater_.update(); });
  }
}

void NodeletDiagnostics::refuse(const std::string& error) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    config_error_ = error;
  }
  updater_.force_update();
}

void NodeletDiagnostics::stop() {
  timer_.stop();
  wall_timer_.stop();
}

void NodeletDiagnostics::run(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!config_error_.empty()) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::ERROR,
                   "invalid configuration: " + config_error_);
      return;
    }
  }
  task_(stat);
}

}  // namespace stereo_safety_map
