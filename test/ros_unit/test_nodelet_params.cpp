// The field lists against everything derived from them or written beside them
// (ARCHITECTURE.md: one declarative field list per config): each nodelet's YAML file has exactly
// its fields with the struct's defaults and [live] where dynamic_reconfigure changes them; the
// README's Parameters lists are what param_table generates and its Core parameters table has
// the defaults; the .cfg files have exactly the live fields with their types, levels, defaults
// and ranges; dynamic_reconfigure's copy-in / copy-back and setCoreParam round-trip every field.
// A failure says what to add where (DEVELOPERS.md, "How to add a parameter").
#include "../core/param_field_checks.h"

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/ros/disparity_params.h"
#include "stereo_safety_map/ros/hybrid_safety_map_params.h"
#include "stereo_safety_map/ros/nodelet_params.h"
#include "stereo_safety_map/ros/obstacle_params.h"
#include "stereo_safety_map/ros/occupancy_grid_2d_params.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/ros/reconfigure_fields.h"
#include "stereo_safety_map/ros/safety_map_params.h"

#include <gtest/gtest.h>
#include <stereo_safety_map/DisparityConfig.h>
#include <stereo_safety_map/SafetyMapConfig.h>
#include <yaml-cpp/yaml.h>

#include <boost/any.hpp>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <regex>
#include <set>
#include <sstream>

namespace ssm = stereo_safety_map;
using param_field_checks::acceptedOtherValue;
using param_field_checks::expectAccessorsRoundTrip;
using param_field_checks::expectRangesMatchValidation;
using ssm::ParamInfo;
using ssm::ParamType;
using ssm::ParamValue;

namespace {

const std::string kSource = SSM_SOURCE_DIR;

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A value as --set and YAML write it (doubles with every digit).
std::string yamlText(const ParamValue& v) {
  if (v.index() == 2) {
    std::ostringstream os;
    os << std::setprecision(17) << std::get<double>(v);
    return os.str();
  }
  return ssm::formatParamValue(v);
}

TEST(NodeletParams, NamesAreUnique) {
  for (const ssm::NodeletParams& n : ssm::allNodeletParams()) {
    std::set<std::string> seen;
    for (const std::string& name : ssm::nodeletParameterNames(n.name))
      EXPECT_TRUE(seen.insert(name).second) << n.name << ": " << name << " twice";
    EXPECT_GT(seen.size(), 10u) << n.name;
  }
  EXPECT_THROW(ssm::nodeletParams("laser"), std::out_of_range);
}

TEST(NodeletParams, RosListsRangesAreWhatValidateAccepts) {
  expectRangesMatchValidation(ssm::safetyMapRosFields(), "safety map nodelet");
  expectRangesMatchValidation(ssm::obstacleCueFields(), "obstacle cue");
  expectRangesMatchValidation(ssm::disparityRosFields(), "disparity nodelet");
  expectRangesMatchValidation(ssm::obstacleDetectionRosFields(), "obstacle detection nodelet");
  expectRangesMatchValidation(ssm::occupancyGrid2DRosFields(), "occupancy 2d nodelet");
  expectRangesMatchValidation(ssm::hybridSafetyMapParamsFields(), "hybrid nodelet");
  expectAccessorsRoundTrip(ssm::safetyMapRosFields(), "safety map nodelet");
  expectAccessorsRoundTrip(ssm::obstacleCueFields(), "obstacle cue");
  expectAccessorsRoundTrip(ssm::disparityRosFields(), "disparity nodelet");
  expectAccessorsRoundTrip(ssm::obstacleDetectionRosFields(), "obstacle detection nodelet");
  expectAccessorsRoundTrip(ssm::occupancyGrid2DRosFields(), "occupancy 2d nodelet");
  expectAccessorsRoundTrip(ssm::hybridSafetyMapParamsFields(), "hybrid nodelet");
}

// --- config/*.yaml ----------------------------------------------------------------------------

// The comment on the line of each top-level key.
std::map<std::string, std::string> keyLineComments(const std::string& path) {
  std::map<std::string, std::string> comments;
  std::ifstream in(path);
  std::string line;
  const std::regex key(R"(^([A-Za-z_][A-Za-z0-9_]*):[^#]*(#.*)?$)");
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_match(line, m, key)) comments[m[1]] = m[2];
  }
  return comments;
}

TEST(NodeletParams, YamlFilesHaveEveryFieldWithItsDefault) {
  for (const ssm::NodeletParams& n : ssm::allNodeletParams()) {
    const std::string path = kSource + "/" + n.yaml;
    YAML::Node root;
    ASSERT_EQ(ssm::loadYamlMap(path, &root), "");
    std::set<std::string> fields;
    for (const ParamInfo& p : n.params) {
      fields.insert(p.name);
      const YAML::Node value = root[p.name];
      if (!value.IsDefined()) {
        ADD_FAILURE() << n.yaml << " lacks " << p.name << " (default "
                      << ssm::formatParamValue(p.default_value) << ")";
        continue;
      }
      ParamValue v;
      ASSERT_EQ(ssm::yamlToParamValue(value, p.type, &v), "") << n.yaml << ": " << p.name;
      EXPECT_EQ(v, p.default_value)
          << n.yaml << ": " << p.name << " is " << ssm::formatParamValue(v)
          << ", the struct's default is " << ssm::formatParamValue(p.default_value);
    }
    for (const auto& kv : root) {
      const std::string key = kv.first.as<std::string>();
      EXPECT_TRUE(fields.count(key)) << n.yaml << ": " << key << " is no field of the " << n.name
                                     << " nodelet (core/config_fields.h, ros/*_params)";
    }
    // [live] in the key's comment exactly for the fields dynamic_reconfigure changes.
    const std::map<std::string, std::string> comments = keyLineComments(path);
    for (const ParamInfo& p : n.params) {
      const auto it = comments.find(p.name);
      if (it == comments.end()) continue;
      const bool marked = it->second.find("[live]") != std::string::npos;
      EXPECT_EQ(marked, p.live()) << n.yaml << ": " << p.name
                                  << (p.live() ? " is live but its comment lacks [live]"
                                               : " is not live but its comment says [live]");
    }
  }
}

// --- README.md --------------------------------------------------------------------------------

TEST(NodeletParams, ReadmeParameterListsAreGenerated) {
  const std::string readme = readFile(kSource + "/README.md");
  ASSERT_FALSE(readme.empty());
  for (const ssm::NodeletParams& n : ssm::allNodeletParams()) {
    const std::string begin = ssm::readmeBeginMarker(n.name);
    const std::string end = ssm::readmeEndMarker(n.name);
    const std::size_t b = readme.find(begin);
    ASSERT_NE(b, std::string::npos) << "README.md has no " << begin;
    const std::size_t e = readme.find(end, b);
    ASSERT_NE(e, std::string::npos) << "README.md has no " << end;
    EXPECT_EQ(readme.substr(b, e + end.size() - b), ssm::readmeParameterBlock(n))
        << "README.md's parameters of " << n.name
        << " are not the field lists': run `param_table --readme README.md`";
  }
  std::string error;
  EXPECT_EQ(ssm::updateReadmeParameterBlocks(readme, &error), readme);
  EXPECT_EQ(error, "");
  ssm::updateReadmeParameterBlocks("no markers", &error);
  EXPECT_NE(error, "");
}

// "| `a` (sym), `b` | 10, 3 m | ..." -> names and the first word of each default.
TEST(NodeletParams, ReadmeCoreParameterTableHasTheDefaults) {
  const std::string readme = readFile(kSource + "/README.md");
  const std::size_t table = readme.find("### Core parameters");
  ASSERT_NE(table, std::string::npos);
  std::map<std::string, ParamValue> defaults;
  for (const ParamInfo& p : ssm::nodeletParams("safety_map").params)
    defaults[p.name] = p.default_value;
  std::istringstream in(readme.substr(table));
  std::string line;
  int rows = 0;
  const std::regex name_re("`([a-z_0-9]+)`");
  while (std::getline(in, line)) {
    if (line.rfind("## ", 0) == 0) break;
    if (line.rfind("| `", 0) != 0) continue;
    const std::size_t bar1 = line.find('|', 1);
    const std::size_t bar2 = line.find('|', bar1 + 1);
    const std::string names_cell = line.substr(1, bar1 - 1);
    const std::string default_cell = line.substr(bar1 + 1, bar2 - bar1 - 1);
    std::vector<std::string> names;
    for (std::sregex_iterator it(names_cell.begin(), names_cell.end(), name_re), e; it != e; ++it)
      names.push_back((*it)[1]);
    std::vector<std::string> values;
    std::stringstream cells(default_cell);
    std::string cell;
    while (std::getline(cells, cell, ',')) {
      std::istringstream words(cell);
      std::string first;
      words >> first;
      values.push_back(first);
    }
    ASSERT_EQ(names.size(), values.size()) << line;
    for (std::size_t i = 0; i < names.size(); ++i) {
      ++rows;
      const auto it = defaults.find(names[i]);
      ASSERT_NE(it, defaults.end()) << "README's Core parameters: " << names[i] << " is no field";
      const ParamValue& d = it->second;
      if (d.index() == 0) {
        EXPECT_EQ(values[i], std::get<bool>(d) ? "true" : "false") << names[i];
      } else {
        const double expected = d.index() == 1 ? std::get<int>(d) : std::get<double>(d);
        EXPECT_DOUBLE_EQ(std::stod(values[i]), expected)
            << "README's Core parameters: " << names[i] << " default " << values[i];
      }
    }
  }
  EXPECT_GT(rows, 30);
}

// --- cfg/*.cfg (through the generated configs) ------------------------------------------------

template <typename T>
ParamValue anyValue(const boost::any& a) {
  return ParamValue(boost::any_cast<T>(a));
}

template <typename Generated>
ParamValue generatedValue(const typename Generated::AbstractParamDescription& d,
                          const Generated& config) {
  boost::any a;
  d.getValue(config, a);
  if (d.type == "bool") return anyValue<bool>(a);
  if (d.type == "int") return anyValue<int>(a);
  if (d.type == "double") return anyValue<double>(a);
  return anyValue<std::string>(a);
}

double asDouble(const ParamValue& v) {
  return v.index() == 1 ? std::get<int>(v) : std::get<double>(v);
}

// An open bound of the list sits just inside the .cfg's closed one (0.001 for (0, ...).
void expectCfgBound(const ParamInfo& p, double cfg, double bound, bool open, bool is_min,
                    const std::string& cfg_name) {
  if (!open) {
    EXPECT_DOUBLE_EQ(cfg, bound) << cfg_name << ": " << p.name << (is_min ? " min" : " max")
                                 << " is " << cfg << ", the field's range is "
                                 << p.range.describe(p.type);
    return;
  }
  const double inside = is_min ? cfg - bound : bound - cfg;
  EXPECT_GT(inside, 0.0) << cfg_name << ": " << p.name << " allows the open bound " << bound;
  EXPECT_LE(inside, 0.01 * (p.range.max - p.range.min))
      << cfg_name << ": " << p.name << (is_min ? " min " : " max ") << cfg
      << " is far inside the field's range " << p.range.describe(p.type);
}

template <typename Generated>
void expectCfgIsTheLiveFields(const ssm::NodeletParams& n) {
  const std::string cfg = n.cfg;
  std::map<std::string, const ParamInfo*> live;
  for (const ParamInfo& p : n.params)
    if (p.live()) live[p.name] = &p;
  std::set<std::string> in_cfg;
  for (const auto& d : Generated::__getParamDescriptions__()) {
    in_cfg.insert(d->name);
    const auto it = live.find(d->name);
    if (it == live.end()) {
      ADD_FAILURE() << cfg << ": " << d->name << " is not a live field of " << n.name
                    << " (.live(level) in its field list)";
      continue;
    }
    const ParamInfo& p = *it->second;
    const char* type = p.type == ParamType::kString ? "str" : ssm::paramTypeName(p.type);
    EXPECT_EQ(d->type, type) << cfg << ": " << p.name;
    EXPECT_EQ(d->level, p.level) << cfg << ": " << p.name << "'s level";
    EXPECT_EQ(generatedValue(*d, Generated::__getDefault__()), p.default_value)
        << cfg << ": " << p.name << "'s default";
    if (p.type == ParamType::kInt || p.type == ParamType::kDouble) {
      const double lo = asDouble(generatedValue(*d, Generated::__getMin__()));
      const double hi = asDouble(generatedValue(*d, Generated::__getMax__()));
      ASSERT_TRUE(p.range.hasMin() && p.range.hasMax())
          << p.name << " is live: its field needs both bounds for the .cfg";
      expectCfgBound(p, lo, p.range.min, p.range.min_open, true, cfg);
      expectCfgBound(p, hi, p.range.max, p.range.max_open, false, cfg);
    }
    for (const std::string& c : p.range.choices) {
      EXPECT_NE(d->edit_method.find("'value': '" + c + "'"), std::string::npos)
          << cfg << ": " << p.name << " has no enum value " << c;
    }
  }
  for (const auto& kv : live) {
    EXPECT_TRUE(in_cfg.count(kv.first))
        << kv.first << " is live (level " << kv.second->level << ") but not in " << cfg;
  }
}

TEST(NodeletParams, CfgFilesAreTheLiveFields) {
  EXPECT_EQ(ssm::nodeletParams("safety_map").cfg, "cfg/SafetyMap.cfg");
  expectCfgIsTheLiveFields<ssm::SafetyMapConfig>(ssm::nodeletParams("safety_map"));
  EXPECT_EQ(ssm::nodeletParams("disparity").cfg, "cfg/Disparity.cfg");
  expectCfgIsTheLiveFields<ssm::DisparityConfig>(ssm::nodeletParams("disparity"));
  for (const ssm::NodeletParams& n : ssm::allNodeletParams()) {
    if (!n.cfg.empty()) continue;
    for (const ParamInfo& p : n.params)
      EXPECT_FALSE(p.live()) << n.name << " has no dynamic_reconfigure but " << p.name
                             << " is live";
  }
}

TEST(NodeletParams, CfgLevelsAreTheCoreConstants) {
  const std::string text = readFile(kSource + "/cfg/SafetyMap.cfg");
  EXPECT_NE(text.find("STAGE, GRID, ROS = " + std::to_string(ssm::SafetyMapLevel::kStage) + ", " +
                      std::to_string(ssm::SafetyMapLevel::kGrid) + ", " +
                      std::to_string(ssm::SafetyMapLevel::kRos)),
            std::string::npos);
  const std::string disparity = readFile(kSource + "/cfg/Disparity.cfg");
  EXPECT_NE(disparity.find("MATCHER = " + std::to_string(ssm::DisparityLevel::kMatcher)),
            std::string::npos);
  EXPECT_NE(disparity.find("FILTER = " + std::to_string(ssm::DisparityLevel::kFilter)),
            std::string::npos);
}

// --- dynamic_reconfigure copy-in / copy-back --------------------------------------------------

template <typename Config, typename Generated>
void expectReconfigureRoundTrip(const ssm::ParamFieldList<Config>& list, const std::string& what) {
  // The generated defaults copy in as the struct's defaults.
  Config from_defaults{};
  ASSERT_EQ(ssm::fromReconfigure(Generated::__getDefault__(), list, &from_defaults), "") << what;
  EXPECT_TRUE(ssm::changedFields(list, Config{}, from_defaults).empty()) << what;
  // Every live field, changed alone, comes back through the generated config, and nothing else.
  int live = 0;
  for (const auto& f : list.fields()) {
    if (!f.info.live()) continue;
    ++live;
    ParamValue v;
    ASSERT_TRUE(acceptedOtherValue(list, f, Config{}, &v)) << f.info.name;
    Config changed{};
    ASSERT_EQ(f.set(&changed, v), "");
    Generated g = Generated::__getDefault__();
    ssm::toReconfigure(changed, list, &g);
    Config back{};
    ASSERT_EQ(ssm::fromReconfigure(g, list, &back), "") << f.info.name;
    EXPECT_EQ(ssm::changedFields(list, Config{}, back), std::vector<std::string>{f.info.name})
        << what << ": " << f.info.name;
    EXPECT_EQ(f.get(back), v) << what << ": " << f.info.name;
  }
  EXPECT_GT(live, 0) << what;
}

TEST(Reconfigure, LiveFieldsRoundTripThroughTheGeneratedConfigs) {
  expectReconfigureRoundTrip<ssm::SafetyMapperConfig, ssm::SafetyMapConfig>(
      ssm::safetyMapperFields(), "SafetyMap.cfg / mapper");
  expectReconfigureRoundTrip<ssm::SafetyMapRosConfig, ssm::SafetyMapConfig>(
      ssm::safetyMapRosFields(), "SafetyMap.cfg / nodelet");
  expectReconfigureRoundTrip<ssm::DisparityPipelineConfig, ssm::DisparityConfig>(
      ssm::disparityPipelineFields(), "Disparity.cfg");
}

TEST(Reconfigure, TheLevelsSayWhatChanged) {
  ssm::SafetyMapperConfig a, b;
  b.grid.decr = 3;
  uint32_t levels = 0;
  ssm::changedFields(ssm::safetyMapperFields(), a, b, &levels);
  EXPECT_EQ(levels, ssm::SafetyMapLevel::kGrid);
  b = a;
  b.labelling.max_slope_deg = 12.0;
  ssm::changedFields(ssm::safetyMapperFields(), a, b, &levels);
  EXPECT_EQ(levels, ssm::SafetyMapLevel::kStage);
  ssm::DisparityConfig g = ssm::DisparityConfig::__getDefault__();
  g.matcher = "census";
  ssm::DisparityPipelineConfig c;
  EXPECT_EQ(ssm::fromReconfigure(g, ssm::disparityPipelineFields(), &c),
            "matcher = 'census' must be 'bm' (StereoBM) or 'sgbm' (StereoSGBM)");
}

// --- loadCoreParams / setCoreParam --------------------------------------------------------------

TEST(CoreParams, SetCoreParamRoundTripsEveryField) {
  const auto& list = ssm::stereoFrameProcessorFields();
  for (const auto& f : list.fields()) {
    ParamValue v;
    ASSERT_TRUE(acceptedOtherValue(list, f, ssm::StereoFrameProcessorConfig{}, &v)) << f.info.name;
    ssm::StereoFrameProcessorConfig c;
    const std::string assignment = f.info.name + "=" + yamlText(v);
    ASSERT_EQ(ssm::setCoreParam(assignment, &c), "") << assignment;
    EXPECT_EQ(f.get(c), v) << assignment;
    EXPECT_EQ(ssm::changedFields(list, ssm::StereoFrameProcessorConfig{}, c),
              std::vector<std::string>{f.info.name})
        << assignment;
  }
}

TEST(CoreParams, SetCoreParamRefusesNamingTheParameter) {
  ssm::StereoFrameProcessorConfig c;
  EXPECT_EQ(ssm::setCoreParam("decrr=3", &c), "--set: unknown core parameter decrr");
  EXPECT_NE(ssm::setCoreParam("decr=0.5", &c).find("decr"), std::string::npos);
  EXPECT_NE(ssm::setCoreParam("decr=0.5", &c).find("an integer"), std::string::npos);
  EXPECT_NE(ssm::setCoreParam("matcher=census", &c).find("matcher"), std::string::npos);
  EXPECT_NE(ssm::setCoreParam("voxel_size=0", &c).find("voxel_size"), std::string::npos);
  EXPECT_NE(ssm::setCoreParam("mark_drop_offs=maybe", &c).find("true or false"), std::string::npos);
  EXPECT_NE(ssm::setCoreParam("decr", &c).find("key=value"), std::string::npos);
  ssm::StereoFrameProcessorConfig fresh;  // a refused value stays in c, as it always has
  ASSERT_EQ(ssm::setCoreParam("block_size=11", &fresh), "");
  EXPECT_EQ(fresh.disparity.texture.window_size, 11) << "the texture window follows the block size";
}

TEST(CoreParams, TheShippedFilesAreTheDefaults) {
  ssm::StereoFrameProcessorConfig c;
  ASSERT_EQ(ssm::loadCoreParams(kSource + "/config/disparity.yaml", &c), "");
  ASSERT_EQ(ssm::loadCoreParams(kSource + "/config/safety_map.yaml", &c), "");
  EXPECT_TRUE(
      ssm::changedFields(ssm::stereoFrameProcessorFields(), ssm::StereoFrameProcessorConfig{}, c)
          .empty());
  ssm::ObstacleDetectionConfig detector;
  ssm::ObstacleDetectionRosConfig detector_ros;
  ASSERT_EQ(ssm::loadObstacleDetectionParams(kSource + "/config/obstacle_detection.yaml", &detector,
                                             &detector_ros),
            "");
  ssm::ObstacleCueRosConfig cue;
  ASSERT_EQ(ssm::loadObstacleCueParams(kSource + "/config/safety_map.yaml", &cue), "");
  ssm::OccupancyGrid2DConfig grid;
  ASSERT_EQ(ssm::loadOccupancyGrid2DParamsFile(kSource + "/config/occupancy_grid_2d.yaml", &grid),
            "");
  EXPECT_NE(ssm::setOccupancyGrid2DParam("kk=3", &grid).find("unknown parameter kk"),
            std::string::npos);
  EXPECT_EQ(ssm::setOccupancyGrid2DParam("fixed_frame=map", &grid), "") << "a nodelet key: ignored";
  EXPECT_EQ(ssm::setOccupancyGrid2DParam("k=30", &grid), "");
  EXPECT_EQ(grid.k, 30);
}

}  // namespace
