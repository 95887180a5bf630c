// The core must stay ROS-free (ARCHITECTURE.md): fail if any core header or source includes a
// ROS header. Catches what compiling cannot, since Debian installs ROS headers under /usr/include.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

std::vector<std::string> rosIncludesIn(const fs::path& dir) {
  // Headers of ROS packages the layer above uses; the core may use std, Eigen, OpenCV only.
  static const std::regex kRosInclude(
      R"(^\s*#\s*include\s*[<"](ros|roscpp|rosbag|nodelet|pluginlib|tf2|tf2_ros|tf2_eigen|)"
      R"(sensor_msgs|stereo_msgs|nav_msgs|geometry_msgs|std_msgs|visualization_msgs|)"
      R"(image_transport|cv_bridge|image_geometry|message_filters|diagnostic_updater|)"
      R"(dynamic_reconfigure|pcl_conversions|pcl_ros|stereo_safety_map/ros)/)");
  std::vector<std::string> offenders;
  if (!fs::exists(dir)) return offenders;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path());
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      if (std::regex_search(line, kRosInclude)) {
        offenders.push_back(entry.path().string() + ":" + std::to_string(number) + ": " + line);
      }
    }
  }
  return offenders;
}

}  // namespace

TEST(NoRosInCore, CoreHeadersAndSourcesIncludeNoRosHeader) {
  const fs::path root(SSM_SOURCE_DIR);
  ASSERT_TRUE(fs::exists(root / "src" / "core")) << root;
  std::vector<std::string> offenders =
      rosIncludesIn(root / "include" / "stereo_safety_map" / "core");
  const auto more = rosIncludesIn(root / "src" / "core");
  offenders.insert(offenders.end(), more.begin(), more.end());
  for (const auto& o : offenders)
    ADD_FAILURE() << "ROS header in the core: " << o;
}

TEST(NoRosInCore, CheckerCatchesARosInclude) {
  // Guard against a checker that can never fail: run it on a planted file.
  const fs::path dir = fs::temp_directory_path() / "ssm_no_ros_check";
  fs::create_directories(dir);
  std::ofstream(dir / "bad.h") << "#pragma once\n#include <ros/ros.h>\n";
  std::ofstream(dir / "good.h") << "#include <Eigen/Core>\n#include <rosy/thing.h>\n";
  const auto offenders = rosIncludesIn(dir);
  fs::remove_all(dir);
  ASSERT_EQ(offenders.size(), 1u);
  EXPECT_NE(offenders[0].find("bad.h:2"), std::string::npos);
}
