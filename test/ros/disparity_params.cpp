// Validated parameter loading of the disparity nodelet: every invalid value is refused with a
// message naming the parameter and its range; config/disparity.yaml is valid, complete and equal
// to the core's defaults; a nodelet with an invalid configuration refuses to run and reports it;
// dynamic_reconfigure forces valid window sizes and refuses what the core refuses.
#include "disparity_test_util.h"

#include "../core/param_field_checks.h"

#include "stereo_safety_map/ros/disparity_params.h"
#include "stereo_safety_map/ros/param_reader.h"

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <gtest/gtest.h>

using stereo_safety_map::DisparityPipelineConfig;
using stereo_safety_map::DisparityRosConfig;
using stereo_safety_map::fromRosParam;

namespace {

int case_counter = 0;

// A fresh private namespace with one parameter set.
template <typename T>
ros::NodeHandle withParam(const std::string& name, const T& value) {
  ros::NodeHandle pnh("/disparity_params_case_" + std::to_string(++case_counter));
  pnh.setParam(name, value);
  return pnh;
}

std::string pipelineError(const ros::NodeHandle& pnh) {
  DisparityPipelineConfig c;
  return fromRosParam(pnh, &c);
}

std::string rosError(const ros::NodeHandle& pnh) {
  DisparityRosConfig c;
  return fromRosParam(pnh, &c);
}

// The message names the parameter and says what is allowed.
void expectRefused(const std::string& err, const std::string& param, const std::string& range) {
  EXPECT_FALSE(err.empty()) << param << " was accepted";
  EXPECT_NE(err.find(param), std::string::npos) << "'" << err << "' does not name " << param;
  EXPECT_NE(err.find(range), std::string::npos) << "'" << err << "' does not give " << range;
}

TEST(DisparityParams, DefaultsAreValid) {
  ros::NodeHandle empty("/disparity_params_empty");
  EXPECT_EQ(pipelineError(empty), "");
  EXPECT_EQ(rosError(empty), "");
}

TEST(DisparityParams, ShippedConfigIsValidCompleteAndTheCoreDefaults) {
  // The nodelet /valid/disparity loaded config/disparity.yaml.
  ros::NodeHandle pnh("/valid/disparity");
  ASSERT_TRUE(test_util::waitFor([&] { return pnh.hasParam("block_size"); }, 10.0));
  for (const std::string& name : stereo_safety_map::disparityParameterNames()) {
    if (name == "diagnostic_period" || name == "image_transport") continue;
    EXPECT_TRUE(pnh.hasParam(name)) << "config/disparity.yaml lacks " << name;
  }
  EXPECT_TRUE(
      stereo_safety_map::unknownParameters(pnh, stereo_safety_map::disparityParameterNames())
          .empty());
  DisparityPipelineConfig yaml, core;
  ASSERT_EQ(fromRosParam(pnh, &yaml), "");
  DisparityRosConfig ros_yaml, ros_defaults;
  ASSERT_EQ(fromRosParam(pnh, &ros_yaml), "");
  EXPECT_EQ(yaml.matcher, core.matcher);
  EXPECT_EQ(yaml.min_disparity, core.min_disparity);
  EXPECT_EQ(yaml.num_disparities, core.num_disparities);
  EXPECT_EQ(yaml.block_size, core.block_size);
  EXPECT_EQ(yaml.pre_filter_cap, core.pre_filter_cap);
  EXPECT_EQ(yaml.bm_texture_threshold, core.bm_texture_threshold);
  EXPECT_EQ(yaml.speckle_window_size, core.speckle_window_size);
  EXPECT_EQ(yaml.speckle_range, core.speckle_range);
  EXPECT_EQ(yaml.sgbm_p1, core.sgbm_p1);
  EXPECT_EQ(yaml.sgbm_p2, core.sgbm_p2);
  EXPECT_EQ(yaml.sgbm_three_way, core.sgbm_three_way);
  EXPECT_EQ(yaml.enable_uniqueness, core.enable_uniqueness);
  EXPECT_EQ(yaml.uniqueness.uniqueness_ratio, core.uniqueness.uniqueness_ratio);
  EXPECT_EQ(yaml.enable_texture, core.enable_texture);
  EXPECT_DOUBLE_EQ(yaml.texture.log_sigma, core.texture.log_sigma);
  EXPECT_EQ(yaml.texture.window_size, core.texture.window_size);
  EXPECT_DOUBLE_EQ(yaml.texture.min_energy, core.texture.min_energy);
  EXPECT_EQ(yaml.enable_left_right, core.enable_left_right);
  EXPECT_DOUBLE_EQ(yaml.left_right.max_difference, core.left_right.max_difference);
  EXPECT_EQ(yaml.left_right.reject_if_right_invalid, core.left_right.reject_if_right_invalid);
  EXPECT_EQ(yaml.left_right_mode, core.left_right_mode);
  EXPECT_EQ(yaml.enable_neighbour_consistency, core.enable_neighbour_consistency);
  EXPECT_EQ(yaml.neighbour_consistency.window_radius, core.neighbour_consistency.window_radius);
  EXPECT_DOUBLE_EQ(yaml.neighbour_consistency.max_difference,
                   core.neighbour_consistency.max_difference);
  EXPECT_DOUBLE_EQ(yaml.neighbour_consistency.min_agreeing_fraction,
                   core.neighbour_consistency.min_agreeing_fraction);
  EXPECT_EQ(yaml.neighbour_consistency.remove_isolated, core.neighbour_consistency.remove_isolated);
  EXPECT_EQ(yaml.enable_spike_removal, core.enable_spike_removal);
  EXPECT_DOUBLE_EQ(yaml.spike_removal.max_difference, core.spike_removal.max_difference);
  EXPECT_EQ(yaml.spike_removal.min_region_size, core.spike_removal.min_region_size);
  EXPECT_EQ(ros_yaml.queue_size, ros_defaults.queue_size);
  EXPECT_EQ(ros_yaml.approximate_sync, ros_defaults.approximate_sync);
  EXPECT_DOUBLE_EQ(ros_yaml.cloud_max_depth, ros_defaults.cloud_max_depth);
}

TEST(DisparityParams, OutOfRangeValuesAreRefused) {
  expectRefused(pipelineError(withParam("matcher", std::string("census"))), "matcher",
                "'bm' (StereoBM) or 'sgbm'");
  expectRefused(pipelineError(withParam("min_disparity", -1)), "min_disparity", "[0, 256]");
  expectRefused(pipelineError(withParam("num_disparities", 40)), "num_disparities",
                "multiple of 16 in [16, 256]");
  expectRefused(pipelineError(withParam("num_disparities", 512)), "num_disparities",
                "multiple of 16 in [16, 256]");
  expectRefused(pipelineError(withParam("block_size", 10)), "block_size", "odd and in [5, 255]");
  expectRefused(pipelineError(withParam("block_size", 3)), "block_size", "[5, 255] for matcher bm");
  expectRefused(pipelineError(withParam("pre_filter_cap", 64)), "pre_filter_cap", "[1, 63]");
  expectRefused(pipelineError(withParam("speckle_range", 65)), "speckle_range", "[0, 64]");
  expectRefused(pipelineError(withParam("uniqueness_ratio", 150)), "uniqueness_ratio", "[0, 100]");
  expectRefused(pipelineError(withParam("texture_log_sigma", 0.0)), "texture_log_sigma", "(0, 10]");
  expectRefused(pipelineError(withParam("texture_window_size", 4)), "texture_window_size",
                "0 (= block_size) or odd and in [1, 255]");
  expectRefused(pipelineError(withParam("texture_min_energy", -1.0)), "texture_min_energy",
                "[0, 1000]");
  expectRefused(pipelineError(withParam("left_right_max_difference", -0.5)),
                "left_right_max_difference", "[0, 256]");
  expectRefused(pipelineError(withParam("neighbour_window_radius", 9)), "neighbour_window_radius",
                "[1, 5]");
  expectRefused(pipelineError(withParam("neighbour_min_agreeing_fraction", 0.0)),
                "neighbour_min_agreeing_fraction", "(0, 1]");
  expectRefused(pipelineError(withParam("spike_max_difference", 0.0)), "spike_max_difference",
                "(0, 256]");
  expectRefused(pipelineError(withParam("spike_min_region_size", 0)), "spike_min_region_size",
                "[1, 1000000]");
  expectRefused(rosError(withParam("queue_size", 0)), "queue_size", "[1, 1000]");
  expectRefused(rosError(withParam("cloud_max_depth", 0.0)), "cloud_max_depth", "(0, 1000]");

  // A disabled filter's settings are checked too (dynamic_reconfigure clamps to the same ranges).
  ros::NodeHandle pnh = withParam("enable_spike_removal", false);
  pnh.setParam("spike_min_region_size", -3);
  expectRefused(pipelineError(pnh), "spike_min_region_size", "[1, 1000000]");

  // A combination the core refuses, in the parameter's own name.
  ros::NodeHandle sgbm = withParam("sgbm_p1", 100);
  sgbm.setParam("sgbm_p2", 50);
  expectRefused(pipelineError(sgbm), "sgbm_p2", "> sgbm_p1");
}

TEST(DisparityParams, WrongTypesAreRefusedNotTruncated) {
  expectRefused(pipelineError(withParam("block_size", 9.5)), "block_size", "an integer");
  expectRefused(pipelineError(withParam("enable_texture", 1)), "enable_texture", "true or false");
  expectRefused(pipelineError(withParam("matcher", 1)), "matcher", "a string");
  expectRefused(pipelineError(withParam("texture_min_energy", std::string("low"))),
                "texture_min_energy", "a number");
  expectRefused(rosError(withParam("approximate_sync", std::string("yes"))), "approximate_sync",
                "true or false");
}

TEST(DisparityParams, TextureWindowFollowsTheBlockSize) {
  DisparityPipelineConfig c;
  ASSERT_EQ(fromRosParam(withParam("block_size", 15), &c), "");
  EXPECT_EQ(c.texture.window_size, 15);
  ros::NodeHandle pnh = withParam("block_size", 15);
  pnh.setParam("texture_window_size", 5);
  ASSERT_EQ(fromRosParam(pnh, &c), "");
  EXPECT_EQ(c.texture.window_size, 5);
  ASSERT_EQ(fromRosParam(withParam("matcher", std::string("sgbm")), &c), "");
  EXPECT_EQ(c.matcher, stereo_safety_map::StereoMatcherType::kSemiGlobal);
}

TEST(DisparityParams, CoreNamesAreTranslatedToParameterNames) {
  EXPECT_EQ(stereo_safety_map::toParameterNames(
                "texture.window_size = 4 must be in odd values of [1, 255]"),
            "texture_window_size = 4 must be in odd values of [1, 255]");
  EXPECT_EQ(stereo_safety_map::toParameterNames("spike_removal.min_region_size = 0"),
            "spike_min_region_size = 0");
  EXPECT_EQ(stereo_safety_map::toParameterNames("uniqueness.uniqueness_ratio = 101"),
            "uniqueness_ratio = 101");
}

// Every field just outside each bound of its range (param_field_checks.h), read by the
// nodelet's own reader: refused, naming the parameter.
template <typename Config>
int expectEveryOutOfRangeValueRefused(const stereo_safety_map::ParamFieldList<Config>& list) {
  int probed = 0;
  for (const auto& f : list.fields()) {
    if (!f.set) continue;
    for (const auto& v : param_field_checks::probesOf(f.info).outside) {
      ros::NodeHandle pnh("/disparity_params_case_" + std::to_string(++case_counter));
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

TEST(DisparityParams, EveryFieldOutOfItsRangeIsRefusedByName) {
  int probed = expectEveryOutOfRangeValueRefused(stereo_safety_map::disparityRosFields());
  probed += expectEveryOutOfRangeValueRefused(stereo_safety_map::disparityPipelineFields());
  EXPECT_GT(probed, 40);
}

TEST(DisparityParams, NodeletRefusesAnInvalidConfiguration) {
  ros::NodeHandle nh;
  test_util::DiagnosticsWatcher diagnostics(nh);
  EXPECT_TRUE(test_util::waitFor(
      [&] {
        return diagnostics.seen("/invalid/disparity", diagnostic_msgs::DiagnosticStatus::ERROR,
                                "block_size");
      },
      20.0))
      << "no ERROR diagnostic naming block_size";
  EXPECT_FALSE(ros::service::exists("/invalid/disparity/set_parameters", false));
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  for (const auto& t : topics) {
    EXPECT_NE(t.name, "/invalid/disparity") << "it publishes a disparity";
  }
  // The valid one next to it in the same manager runs.
  EXPECT_TRUE(ros::service::waitForService("/valid/disparity/set_parameters", 10000));
}

TEST(DisparityParams, ReconfigureForcesValidWindowSizes) {
  const std::string node = "/valid/disparity";
  dynamic_reconfigure::Config result;
  // Even block sizes become odd, ranges round down to a multiple of 16 (as stereo_image_proc).
  ASSERT_TRUE(
      disparity_test::reconfigure(node, disparity_test::intConfig("block_size", 10), &result));
  EXPECT_EQ(disparity_test::intValue(result, "block_size"), 11);
  ASSERT_TRUE(
      disparity_test::reconfigure(node, disparity_test::intConfig("num_disparities", 40), &result));
  EXPECT_EQ(disparity_test::intValue(result, "num_disparities"), 32);
  ASSERT_TRUE(disparity_test::reconfigure(node, disparity_test::intConfig("texture_window_size", 6),
                                          &result));
  EXPECT_EQ(disparity_test::intValue(result, "texture_window_size"), 7);
  // What the core refuses is refused and the previous values come back.
  dynamic_reconfigure::Config sgbm = disparity_test::intConfig("sgbm_p1", 100);
  sgbm.ints.push_back(disparity_test::intConfig("sgbm_p2", 50).ints[0]);
  ASSERT_TRUE(disparity_test::reconfigure(node, sgbm, &result));
  EXPECT_EQ(disparity_test::intValue(result, "sgbm_p1"), 0);
  EXPECT_EQ(disparity_test::intValue(result, "sgbm_p2"), 0);
  EXPECT_EQ(disparity_test::intValue(result, "block_size"), 11);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "disparity_params_test");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
