#include "stereo_safety_map/ros/disparity_params.h"

#include "stereo_safety_map/ros/param_reader.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <cmath>
#include <sstream>

namespace stereo_safety_map {

namespace {

// Core name (DisparityPipelineConfig::validate()) -> parameter name. Longest names first, so that
// "texture.window_size" is replaced before a shorter name could match inside it.
const std::pair<const char*, const char*> kCoreToParameter[] = {
    {"uniqueness.max_normalized_cost", "uniqueness_max_normalized_cost"},
    {"uniqueness.uniqueness_ratio", "uniqueness_ratio"},
    {"texture.log_sigma", "texture_log_sigma"},
    {"texture.window_size", "texture_window_size"},
    {"texture.min_energy", "texture_min_energy"},
    {"left_right.max_difference", "left_right_max_difference"},
    {"neighbour_consistency.window_radius", "neighbour_window_radius"},
    {"neighbour_consistency.max_difference", "neighbour_max_difference"},
    {"neighbour_consistency.min_agreeing_fraction", "neighbour_min_agreeing_fraction"},
    {"spike_removal.max_difference", "spike_max_difference"},
    {"spike_removal.min_region_size", "spike_min_region_size"},
};

// Reads typed parameters, remembering the first error (param_reader.h).
using Reader = ParamReader;

// Range checks; the first failure wins. The ranges are those of cfg/Disparity.cfg.
class RangeCheck {
 public:
  template <typename T>
  void closed(const char* name, T value, T lo, T hi) {
    if (!error_.empty()) return;
    if (!(value >= lo && value <= hi)) set(name, value, "[", lo, hi, "]");
  }
  void openClosed(const char* name, double value, double lo, double hi) {
    if (!error_.empty()) return;
    if (!(value > lo && value <= hi)) set(name, value, "(", lo, hi, "]");
  }
  void fail(const std::string& message) {
    if (error_.empty()) error_ = message;
  }
  const std::string& error() const { return error_; }

 private:
  template <typename T>
  void set(const char* name, T value, const char* open, T lo, T hi, const char* close) {
    std::ostringstream os;
    os << name << " = " << value << " must be in " << open << lo << ", " << hi << close;
    error_ = os.str();
  }
  std::string error_;
};

}  // namespace

const char* matcherName(StereoMatcherType type) {
  return type == StereoMatcherType::kSemiGlobal ? "sgbm" : "bm";
}

bool matcherFromName(const std::string& name, StereoMatcherType* type) {
  if (name == "bm") {
    *type = StereoMatcherType::kBlockMatching;
  } else if (name == "sgbm") {
    *type = StereoMatcherType::kSemiGlobal;
  } else {
    return false;
  }
  return true;
}

std::string toParameterNames(const std::string& core_message) {
  std::string s = core_message;
  for (const auto& names : kCoreToParameter) {
    const std::string from = names.first;
    for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at)) {
      s.replace(at, from.size(), names.second);
      at += std::char_traits<char>::length(names.second);
    }
  }
  return s;
}

std::string validateDisparityParameters(const DisparityPipelineConfig& c,
                                        int texture_window_param) {
  RangeCheck r;
  r.closed("min_disparity", c.min_disparity, 0, 256);
  if (r.error().empty() &&
      (c.num_disparities < 16 || c.num_disparities > 256 || c.num_disparities % 16 != 0)) {
    r.fail("num_disparities = " + std::to_string(c.num_disparities) +
           " must be a multiple of 16 in [16, 256]");
  }
  const int min_block = c.matcher == StereoMatcherType::kBlockMatching ? 5 : 1;
  if (r.error().empty() &&
      (c.block_size % 2 == 0 || c.block_size < min_block || c.block_size > 255)) {
    r.fail("block_size = " + std::to_string(c.block_size) + " must be odd and in [" +
           std::to_string(min_block) + ", 255]" +
           (min_block == 5 ? " for matcher bm" : " for matcher sgbm"));
  }
  r.closed("pre_filter_cap", c.pre_filter_cap, 1, 63);
  r.closed("bm_texture_threshold", c.bm_texture_threshold, 0, 10000);
  r.closed("speckle_window_size", c.speckle_window_size, 0, 10000);
  r.closed("speckle_range", c.speckle_range, 0, 64);
  r.closed("sgbm_p1", c.sgbm_p1, 0, 1000000);
  r.closed("sgbm_p2", c.sgbm_p2, 0, 1000000);
  r.closed("uniqueness_ratio", c.uniqueness.uniqueness_ratio, 0, 100);
  r.openClosed("texture_log_sigma", c.texture.log_sigma, 0.0, 10.0);
  if (r.error().empty() && texture_window_param != 0 &&
      (texture_window_param % 2 == 0 || texture_window_param < 1 || texture_window_param > 255)) {
    r.fail("texture_window_size = " + std::to_string(texture_window_param) +
           " must be 0 (= block_size) or odd and in [1, 255]");
  }
  r.closed("texture_min_energy", c.texture.min_energy, 0.0, 1000.0);
  r.closed("left_right_max_difference", c.left_right.max_difference, 0.0, 256.0);
  r.closed("neighbour_window_radius", c.neighbour_consistency.window_radius, 1, 5);
  r.closed("neighbour_max_difference", c.neighbour_consistency.max_difference, 0.0, 256.0);
  r.openClosed("neighbour_min_agreeing_fraction", c.neighbour_consistency.min_agreeing_fraction,
               0.0, 1.0);
  r.openClosed("spike_max_difference", c.spike_removal.max_difference, 0.0, 256.0);
  r.closed("spike_min_region_size", c.spike_removal.min_region_size, 1, 1000000);
  if (!r.error().empty()) return r.error();
  return toParameterNames(c.validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, DisparityPipelineConfig* c) {
  Reader r(pnh);
  std::string matcher = matcherName(c->matcher);
  r.read("matcher", &matcher);
  if (r.error().empty() && !matcherFromName(matcher, &c->matcher)) {
    return r.result("matcher = '" + matcher + "' must be 'bm' (StereoBM) or 'sgbm' (StereoSGBM)");
  }
  r.read("min_disparity", &c->min_disparity);
  r.read("num_disparities", &c->num_disparities);
  r.read("block_size", &c->block_size);
  r.read("pre_filter_cap", &c->pre_filter_cap);
  r.read("bm_texture_threshold", &c->bm_texture_threshold);
  r.read("speckle_window_size", &c->speckle_window_size);
  r.read("speckle_range", &c->speckle_range);
  r.read("sgbm_p1", &c->sgbm_p1);
  r.read("sgbm_p2", &c->sgbm_p2);
  r.read("sgbm_three_way", &c->sgbm_three_way);

  r.read("enable_uniqueness", &c->enable_uniqueness);
  r.read("uniqueness_ratio", &c->uniqueness.uniqueness_ratio);
  r.read("enable_texture", &c->enable_texture);
  r.read("texture_log_sigma", &c->texture.log_sigma);
  int texture_window = 0;
  r.read("texture_window_size", &texture_window);
  r.read("texture_min_energy", &c->texture.min_energy);
  r.read("enable_left_right", &c->enable_left_right);
  r.read("left_right_max_difference", &c->left_right.max_difference);
  r.read("left_right_reject_if_right_invalid", &c->left_right.reject_if_right_invalid);
  r.read("parallel_left_right", &c->parallel_left_right);
  r.read("enable_neighbour_consistency", &c->enable_neighbour_consistency);
  r.read("neighbour_window_radius", &c->neighbour_consistency.window_radius);
  r.read("neighbour_max_difference", &c->neighbour_consistency.max_difference);
  r.read("neighbour_min_agreeing_fraction", &c->neighbour_consistency.min_agreeing_fraction);
  r.read("neighbour_remove_isolated", &c->neighbour_consistency.remove_isolated);
  r.read("enable_spike_removal", &c->enable_spike_removal);
  r.read("spike_max_difference", &c->spike_removal.max_difference);
  r.read("spike_min_region_size", &c->spike_removal.min_region_size);
  if (!r.error().empty()) return r.error();
  c->texture.window_size = texture_window == 0 ? c->block_size : texture_window;
  return r.result(validateDisparityParameters(*c, texture_window));
}

std::string DisparityRosConfig::validate() const {
  RangeCheck r;
  r.closed("queue_size", queue_size, 1, 1000);
  r.openClosed("cloud_max_depth", cloud_max_depth, 0.0, 1000.0);
  r.closed("min_image_contrast", min_image_contrast, 0.0, 128.0);
  return r.error();
}

std::string fromRosParam(const ros::NodeHandle& pnh, DisparityRosConfig* c) {
  Reader r(pnh);
  r.read("queue_size", &c->queue_size);
  r.read("approximate_sync", &c->approximate_sync);
  r.read("cloud_max_depth", &c->cloud_max_depth);
  r.read("min_image_contrast", &c->min_image_contrast);
  r.read("reject_frozen_images", &c->reject_frozen_images);
  return r.result(c->validate());
}

std::vector<std::string> disparityParameterNames() {
  return {// DisparityPipelineConfig: matcher
          "matcher", "min_disparity", "num_disparities", "block_size", "pre_filter_cap",
          "bm_texture_threshold", "speckle_window_size", "speckle_range", "sgbm_p1", "sgbm_p2",
          "sgbm_three_way",
          // post-filters
          "enable_uniqueness", "uniqueness_ratio", "enable_texture", "texture_log_sigma",
          "texture_window_size", "texture_min_energy", "enable_left_right",
          "left_right_max_difference", "left_right_reject_if_right_invalid", "parallel_left_right",
          "enable_neighbour_consistency", "neighbour_window_radius", "neighbour_max_difference",
          "neighbour_min_agreeing_fraction", "neighbour_remove_isolated", "enable_spike_removal",
          "spike_max_difference", "spike_min_region_size",
          // DisparityRosConfig
          "queue_size", "approximate_sync", "cloud_max_depth", "min_image_contrast",
          "reject_frozen_images",
          // read by diagnostic_updater and image_transport (transport hints)
          "diagnostic_period", "image_transport"};
}

}  // namespace stereo_safety_map
