#include "stereo_safety_map/ros/nodelet_shell.h"

#include "stereo_safety_map/ros/param_reader.h"

namespace stereo_safety_map {

NodeletShell::NodeletShell(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), name_(pnh.getNamespace()), problems_(name_) {}

NodeletShell::~NodeletShell() {
  if (diagnostics_) diagnostics_->stop();
}

void NodeletShell::startDiagnostics(const std::string& hardware_id, const std::string& task_name,
                                    NodeletDiagnostics::Task task,
                                    NodeletDiagnostics::Clock clock) {
  diagnostics_ = std::make_unique<NodeletDiagnostics>(nh_, pnh_, name_, hardware_id, task_name,
                                                      std::move(task), clock);
}

void NodeletShell::refuse(const std::string& error) {
  config_error_ = error;
  ROS_ERROR_STREAM(name_ << ": refusing to start with an invalid configuration: " << error);
  if (diagnostics_) diagnostics_->refuse(config_error_);
}

bool NodeletShell::acceptParams(const std::string& error, const std::vector<std::string>& known) {
  if (!error.empty()) {
    refuse(error);
    return false;
  }
  for (const std::string& p : unknownParameters(pnh_, known)) {
    ROS_WARN_STREAM(name_ << ": ignoring unknown parameter ~" << p << " (a typo?)");
  }
  return true;
}

}  // namespace stereo_safety_map
