// Validated parameter loading: every invalid value is refused with a message naming the
// parameter and its range; config/safety_map.yaml itself is valid and complete; a nodelet with an
// invalid configuration refuses to run and reports it in /diagnostics.
#include "test_util.h"

#include "../core/param_field_checks.h"

#include "stereo_safety_map/ros/obstacle_params.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/safety_map_params.h"

#include <gtest/gtest.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>

using stereo_safety_map::fromRosParam;
using stereo_safety_map::SafetyMapperConfig;
using stereo_safety_map::SafetyMapRosConfig;

namespace {

int case_counter = 0;

// A fresh private namespace with one parameter set.
template <typename T>
ros::NodeHandle withParam(const std::string& name, const T& value) {
  ros::NodeHandle pnh("/params_case_" + std::to_string(++case_counter));
  pnh.setParam(name, value);
  return pnh;
}

std::string mapperError(const ros::NodeHandle& pnh) {
  SafetyMapperConfig c;
  return fromRosParam(pnh, &c);
}

std::string rosError(const ros::NodeHandle& pnh) {
  SafetyMapRosConfig c;
  return fromRosParam(pnh, &c);
}

// The message names the parameter and says what is allowed.
void expectRefused(const std::string& err, const std::string& param, const std::string& range) {
  EXPECT_FALSE(err.empty()) << param << " was accepted";
  EXPECT_NE(err.find(param), std::string::npos) << "'" << err << "' does not name " << param;
  EXPECT_NE(err.find(range), std::string::npos) << "'" << err << "' does not give " << range;
}

TEST(Params, DefaultsAreValid) {
  ros::NodeHandle empty("/params_empty");
  EXPECT_EQ(mapperError(empty), "");
  EXPECT_EQ(rosError(empty), "");
}

TEST(Params, ShippedConfigIsValidAndHasEveryParameter) {
  // The nodelet /valid/safety_map loaded config/safety_map.yaml.
  ros::NodeHandle pnh("/valid/safety_map");
  ASSERT_TRUE(test_util::waitFor([&] { return pnh.hasParam("decr"); }, 10.0));
  EXPECT_EQ(mapperError(pnh), "");
  EXPECT_EQ(rosError(pnh), "");
  for (const std::string& name : stereo_safety_map::safetyMapParameterNames()) {
    EXPECT_TRUE(pnh.hasParam(name)) << "config/safety_map.yaml lacks " << name;
  }
  // The shipped values are the core's defaults (the paper's).
  SafetyMapperConfig from_yaml, defaults;
  ASSERT_EQ(fromRosParam(pnh, &from_yaml), "");
  EXPECT_EQ(from_yaml.grid.decr, defaults.grid.decr);
  EXPECT_EQ(from_yaml.grid.occ_threshold, defaults.grid.occ_threshold);
  EXPECT_DOUBLE_EQ(from_yaml.segmentation.planning_radius, defaults.segmentation.planning_radius);
  EXPECT_DOUBLE_EQ(from_yaml.labelling.max_slope_deg, defaults.labelling.max_slope_deg);
  EXPECT_DOUBLE_EQ(from_yaml.labelling.level_slope_deg, defaults.labelling.level_slope_deg);
}

TEST(Params, OutOfRangeValuesAreRefused) {
  expectRefused(mapperError(withParam("voxel_size", 0.0)), "voxel_size", "> 0");
  expectRefused(mapperError(withParam("decr", -1)), "decr", "[0, 32767]");
  expectRefused(mapperError(withParam("occ_threshold", 0)), "occ_threshold", "lop_max");
  expectRefused(mapperError(withParam("robot_height", -1.0)), "robot_height", "(0, 100]");
  expectRefused(mapperError(withParam("planning_radius", 0.0)), "planning_radius", "(0, 1000]");
  expectRefused(mapperError(withParam("connectivity", 6)), "connectivity", "4 or 8");
  expectRefused(mapperError(withParam("min_points", 2)), "min_points", "[3, 1000000]");
  expectRefused(mapperError(withParam("max_slope_deg", 95.0)), "max_slope_deg", "(0, 90)");
  expectRefused(mapperError(withParam("level_slope_deg", 20.0)), "level_slope_deg",
                "max_slope_deg");
  expectRefused(mapperError(withParam("stationary_translation", -0.1)), "stationary_translation",
                "[0, 100]");
  expectRefused(rosError(withParam("input", std::string("laser"))), "input",
                "'disparity' or 'cloud'");
  expectRefused(rosError(withParam("queue_size", 0)), "queue_size", "[1, 1000]");
  expectRefused(rosError(withParam("max_rate", -5.0)), "max_rate", "[0, 1000]");
  expectRefused(rosError(withParam("disparity_step", 0)), "disparity_step", "[1, 16]");
  expectRefused(rosError(withParam("fixed_frame", std::string(""))), "fixed_frame", "tf frame");
}

TEST(Params, WrongTypesAreRefusedNotTruncated) {
  expectRefused(mapperError(withParam("decr", 0.5)), "decr", "an integer");
  expectRefused(mapperError(withParam("voxel_size", std::string("small"))), "voxel_size",
                "a number");
  expectRefused(mapperError(withParam("mark_drop_offs", 1)), "mark_drop_offs", "true or false");
  expectRefused(rosError(withParam("fixed_frame", 3)), "fixed_frame", "a string");
}

TEST(Params, IntegersAreAcceptedForDoubles) {
  SafetyMapperConfig c;
  EXPECT_EQ(fromRosParam(withParam("planning_radius", 3), &c), "");
  EXPECT_DOUBLE_EQ(c.segmentation.planning_radius, 3.0);
}

TEST(Params, UnknownParametersAreReported) {
  ros::NodeHandle pnh = withParam("decrr", 3);
  pnh.setParam("decr", 3);
  const auto unknown =
      stereo_safety_map::unknownParameters(pnh, stereo_safety_map::safetyMapParameterNames());
  ASSERT_EQ(unknown.size(), 1u);
  EXPECT_EQ(unknown[0], "decrr");
}

// Every field of `list` just outside each bound of its range (param_field_checks.h), read by
// the nodelet's own reader: refused, naming the parameter.
template <typename Config>
int expectEveryOutOfRangeValueRefused(const stereo_safety_map::ParamFieldList<Config>& list) {
  int probed = 0;
  for (const auto& f : list.fields()) {
    if (!f.set) continue;
    for (const auto& v : param_field_checks::probesOf(f.info).outside) {
      ros::NodeHandle pnh("/params_case_" + std::to_string(++case_counter));
      std::visit([&](const auto& value) { pnh.setParam(f.info.name, value); }, v);
      Config c{};
      const std::string err = fromRosParam(pnh, &c);
      EXPECT_NE(err.find("invalid parameter"), std::string::npos)
          << f.info.name << " = " << stereo_safety_map::formatParamValue(v) << ": " << err;
      EXPECT_NE(param_field_checks::wordAt(err, f.info.name), std::string::npos)
          << f.info.name << " = " << stereo_safety_map::formatParamValue(v)
          << " refused without naming it: " << err;
      ++probed;
    }
  }
  return probed;
}

TEST(Params, EveryFieldOutOfItsRangeIsRefusedByName) {
  int probed = expectEveryOutOfRangeValueRefused(stereo_safety_map::safetyMapRosFields());
  probed += expectEveryOutOfRangeValueRefused(stereo_safety_map::safetyMapperFields());
  probed += expectEveryOutOfRangeValueRefused(stereo_safety_map::landmarkStreamFields());
  probed += expectEveryOutOfRangeValueRefused(stereo_safety_map::obstacleCueFields());
  EXPECT_GT(probed, 60);
}

TEST(Params, NodeletRefusesAnInvalidConfiguration) {
  ros::NodeHandle nh;
  test_util::DiagnosticsWatcher diagnostics(nh);
  EXPECT_TRUE(test_util::waitFor(
      [&] {
        return diagnostics.seen("/invalid/safety_map", diagnostic_msgs::DiagnosticStatus::ERROR,
                                "occ_threshold");
      },
      20.0))
      << "no ERROR diagnostic naming occ_threshold";
  // It runs nothing: no map topic, no services.
  EXPECT_FALSE(ros::service::exists("/invalid/safety_map/reset", false));
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  for (const auto& t : topics)
    EXPECT_NE(t.name, "/invalid/safety_map") << "it publishes a map";
  // The valid one next to it in the same manager runs.
  EXPECT_TRUE(ros::service::waitForService("/valid/safety_map/reset", 10000));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "safety_map_params_test");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
