#include "stereo_safety_map/ros/stereo_input_fields.h"

#include <cmath>
#include <sstream>

namespace stereo_safety_map {

namespace {

// "" when lo <= value <= hi (and finite), else "<name> = <value>, must be in [lo, hi]<unit>".
std::string closedRangeError(const char* name, double value, double lo, double hi,
                             const char* unit) {
  if (std::isfinite(value) && value >= lo && value <= hi) return "";
  std::ostringstream os;
  os << name << " = " << value << ", must be in [" << lo << ", " << hi << "]" << unit;
  return os.str();
}

}  // namespace

std::string inputError(const std::string& input) {
  if (input == "disparity" || input == "cloud") return "";
  return "input = '" + input + "', must be 'disparity' or 'cloud'";
}

std::string frameError(const char* name, const std::string& frame, const char* must_name) {
  if (!frame.empty()) return "";
  return std::string(name) + " is empty, must name " + must_name;
}

std::string queueSizeError(int queue_size) {
  if (queue_size >= 1 && queue_size <= 1000) return "";
  return "queue_size = " + std::to_string(queue_size) + ", must be in [1, 1000]";
}

std::string maxRateError(double max_rate) {
  return closedRangeError("max_rate", max_rate, 0, 1000, " Hz (0 = every frame)");
}

std::string tfTimeoutError(double tf_timeout) {
  return closedRangeError("tf_timeout", tf_timeout, 0, 10, " s");
}

std::string timeJumpResetError(double time_jump_reset) {
  return closedRangeError("time_jump_reset", time_jump_reset, 0, 3600, " s");
}

std::string firstError(std::initializer_list<std::string> errors) {
  for (const std::string& e : errors) {
    if (!e.empty()) return e;
  }
  return "";
}

}  // namespace stereo_safety_map
