// The field-list facility (core/param_fields.h) and the core's lists (core/config_fields.h):
// accessors through nested structs and getter / setter pairs, lists included in others, the
// README lines, and every list's ranges against its config's validate(). The YAML files, the
// README and the .cfg files are compared with the lists in test/ros_unit/test_nodelet_params.cpp.
#include "param_field_checks.h"

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/param_fields.h"

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <set>
#include <string>

namespace ssm = stereo_safety_map;
using param_field_checks::expectAccessorsRoundTrip;
using param_field_checks::expectRangesMatchValidation;
using ssm::ParamFieldList;
using ssm::ParamInfo;
using ssm::ParamType;
using ssm::ParamValue;

namespace {

struct Inner {
  double gain = 0.5;
  int count = 3;
};

struct Outer {
  Inner inner;
  bool on = true;
  std::string mode = "a";
  int code = 1;  ///< stored as a number, a name as parameter: 1 = "a", 2 = "b"
};

struct Top {
  Outer outer;
  int extra = 7;
};

// `count_max` and `gain_max` document other ranges than validate() checks, for the guard test.
ParamFieldList<Outer> outerList(double count_max = 10, double gain_max = 1) {
  ParamFieldList<Outer> l;
  l.section("First");
  l.add("gain", &Outer::inner, &Inner::gain)
      .openClosed(0, gain_max)
      .unit("m")
      .doc("a gain (ours).");
  l.add("count", &Outer::inner, &Inner::count).closed(1, count_max).live(2).doc("a count.");
  l.section("Second");
  l.add("on", &Outer::on).doc("a switch.");
  l.add("mode", &Outer::mode).oneOf({"a", "b"}).doc("a mode.");
  l.addAccessor<std::string>(
       "code", [](const Outer& o) { return std::string(o.code == 2 ? "b" : "a"); },
       [](Outer* o, const std::string& v) -> std::string {
         if (v != "a" && v != "b") return "code = '" + v + "' must be 'a' or 'b'";
         o->code = v == "b" ? 2 : 1;
         return "";
       })
      .oneOf({"a", "b"})
      .doc("a code.");
  l.addExternal("period", 1.0).unit("s").doc("read by a library.");
  l.setValidator([](const Outer& o) -> std::string {
    if (!(o.inner.gain > 0.0 && o.inner.gain <= 1.0)) return "gain must be in (0, 1]";
    if (o.inner.count < 1 || o.inner.count > 10) return "count must be in [1, 10]";
    if (o.mode != "a" && o.mode != "b") return "mode must be a or b";
    return "";
  });
  return l;
}

TEST(ParamFields, AccessorsReachNestedMembersAndGetterSetterPairs) {
  const ParamFieldList<Outer> l = outerList();
  Outer o;
  ASSERT_NE(l.find("gain"), nullptr);
  EXPECT_EQ(l.find("gain")->info.type, ParamType::kDouble);
  EXPECT_EQ(l.find("gain")->get(o), ParamValue(0.5));
  EXPECT_EQ(l.find("gain")->set(&o, ParamValue(0.25)), "");
  EXPECT_DOUBLE_EQ(o.inner.gain, 0.25);
  EXPECT_EQ(l.find("count")->info.type, ParamType::kInt);
  EXPECT_EQ(l.find("on")->info.type, ParamType::kBool);
  EXPECT_EQ(l.find("mode")->info.type, ParamType::kString);
  EXPECT_EQ(l.find("code")->set(&o, ParamValue(std::string("b"))), "");
  EXPECT_EQ(o.code, 2);
  EXPECT_EQ(l.find("code")->get(o), ParamValue(std::string("b")));
  EXPECT_EQ(l.find("code")->set(&o, ParamValue(std::string("c"))), "code = 'c' must be 'a' or 'b'");
  EXPECT_EQ(o.code, 2);
  EXPECT_EQ(l.find("nothing"), nullptr);
  EXPECT_FALSE(l.find("period")->set);
  EXPECT_TRUE(l.find("period")->info.external);
}

TEST(ParamFields, InfosTakeTheDefaultsFromTheStruct) {
  const std::vector<ParamInfo> infos = outerList().infos();
  ASSERT_EQ(infos.size(), 6u);
  EXPECT_EQ(infos[0].name, "gain");
  EXPECT_EQ(infos[0].default_value, ParamValue(0.5));
  EXPECT_EQ(infos[0].section, "First");
  EXPECT_EQ(infos[1].default_value, ParamValue(3));
  EXPECT_TRUE(infos[1].live());
  EXPECT_EQ(infos[2].section, "Second");
  EXPECT_EQ(infos[3].default_value, ParamValue(std::string("a")));
  EXPECT_EQ(infos[5].default_value, ParamValue(1.0));
}

TEST(ParamFields, IncludedListsReachThroughTheMember) {
  ParamFieldList<Top> l;
  l.include(outerList(), &Top::outer);
  l.add("extra", &Top::extra);
  Top t;
  EXPECT_EQ(l.names(),
            (std::vector<std::string>{"gain", "count", "on", "mode", "code", "period", "extra"}));
  EXPECT_EQ(l.find("count")->set(&t, ParamValue(9)), "");
  EXPECT_EQ(t.outer.inner.count, 9);
  EXPECT_EQ(l.find("count")->info.level, 2u);
  EXPECT_EQ(l.find("count")->info.section, "First");
  EXPECT_EQ(l.find("code")->set(&t, ParamValue(std::string("x"))), "code = 'x' must be 'a' or 'b'");
  EXPECT_FALSE(l.find("period")->set);
  uint32_t levels = 0;
  Top u = t;
  u.outer.on = false;
  EXPECT_EQ(ssm::changedFields(l, t, u, &levels), std::vector<std::string>{"on"});
  EXPECT_EQ(levels, 0u);
  EXPECT_EQ(ssm::changedFields(l, Top{}, t, &levels), std::vector<std::string>{"count"});
  EXPECT_EQ(levels, 2u);
}

TEST(ParamFields, RangesAndReadmeLines) {
  ssm::ParamRange r;
  EXPECT_EQ(r.describe(ParamType::kDouble), "");
  r.min = 0;
  r.min_open = true;
  EXPECT_EQ(r.describe(ParamType::kDouble), "> 0");
  r.max = 10;
  EXPECT_EQ(r.describe(ParamType::kDouble), "(0, 10]");
  r.min_open = false;
  r.max_open = true;
  EXPECT_EQ(r.describe(ParamType::kDouble), "[0, 10)");
  r.text = "[0, size_z]";
  EXPECT_EQ(r.describe(ParamType::kDouble), "[0, size_z]");
  ssm::ParamRange choices;
  choices.choices = {"4", "8"};
  EXPECT_EQ(choices.describe(ParamType::kInt), "4 | 8");
  choices.choices = {"bm", "sgbm"};
  EXPECT_EQ(choices.describe(ParamType::kString), "`bm` | `sgbm`");

  const std::vector<ParamInfo> infos = outerList().infos();
  EXPECT_EQ(ssm::markdownLine(infos[0]), "- `~gain` (double, 0.5 m, (0, 1]): a gain (ours).");
  EXPECT_EQ(ssm::markdownLine(infos[1]), "- `~count` (int, 3, [1, 10]) [live]: a count.");
  EXPECT_EQ(ssm::markdownLine(infos[2]), "- `~on` (bool, true): a switch.");
  EXPECT_EQ(ssm::markdownLine(infos[3]), "- `~mode` (string, `a`, `a` | `b`): a mode.");
  EXPECT_EQ(ssm::markdownList({infos[1], infos[2]}),
            "First:\n- `~count` (int, 3, [1, 10]) [live]: a count.\n\nSecond:\n"
            "- `~on` (bool, true): a switch.\n");
  EXPECT_EQ(ssm::formatParamValue(ParamValue(0.00025)), "0.00025");
  EXPECT_EQ(ssm::formatParamValue(ParamValue(11.345)), "11.345");
  EXPECT_EQ(ssm::formatParamValue(ParamValue(400000)), "400000");
  EXPECT_EQ(ssm::formatParamValue(ParamValue(1.0)), "1");
  EXPECT_EQ(ssm::formatParamValue(ParamValue(1e6)), "1000000");
  EXPECT_EQ(ssm::formatParamValue(ParamValue(-0.4)), "-0.4");
  ParamInfo voxels;
  voxels.name = "span";
  voxels.type = ParamType::kInt;
  voxels.unit = "voxels";
  voxels.default_value = ParamValue(1);
  EXPECT_EQ(ssm::markdownLine(voxels), "- `~span` (int, 1 voxel): ");
  voxels.default_value = ParamValue(2);
  EXPECT_EQ(ssm::markdownLine(voxels), "- `~span` (int, 2 voxels): ");
  voxels.unit = "s";
  voxels.default_value = ParamValue(1);
  EXPECT_EQ(ssm::markdownLine(voxels), "- `~span` (int, 1 s): ");
}

TEST(ParamFields, TheProbesCatchARangeValidateDoesNotCheck) {
  // Guard against checks that cannot fail: a list whose documented range is narrower than what
  // validate() accepts, and one whose range is wider.
  const ParamFieldList<Outer> narrow = outerList(5);
  ::testing::TestPartResultArray failures;
  {
    ::testing::ScopedFakeTestPartResultReporter reporter(
        ::testing::ScopedFakeTestPartResultReporter::INTERCEPT_ONLY_CURRENT_THREAD, &failures);
    expectRangesMatchValidation(narrow, "narrow");
  }
  EXPECT_GT(failures.size(), 0) << "count = 6 is accepted by validate() but outside [1, 5]";

  const ParamFieldList<Outer> wide = outerList(10, 2);
  ::testing::TestPartResultArray wide_failures;
  {
    ::testing::ScopedFakeTestPartResultReporter reporter(
        ::testing::ScopedFakeTestPartResultReporter::INTERCEPT_ONLY_CURRENT_THREAD, &wide_failures);
    expectRangesMatchValidation(wide, "wide");
  }
  EXPECT_GT(wide_failures.size(), 0) << "gain = 2 is refused by validate() but inside (0, 2]";

  // The list as written passes.
  expectRangesMatchValidation(outerList(), "outer");
  expectAccessorsRoundTrip(outerList(), "outer");
}

template <typename Config>
void expectUniqueDocumentedNames(const ParamFieldList<Config>& list, const std::string& what) {
  std::set<std::string> seen;
  for (const auto& f : list.fields()) {
    EXPECT_TRUE(seen.insert(f.info.name).second) << what << ": " << f.info.name << " twice";
    EXPECT_FALSE(f.info.doc.empty()) << what << ": " << f.info.name << " has no doc";
    EXPECT_EQ(f.info.doc.back(), '.') << what << ": " << f.info.name << "'s doc is not a sentence";
    EXPECT_FALSE(f.info.section.empty()) << what << ": " << f.info.name << " has no section";
  }
}

TEST(CoreFieldLists, NamesAreUniqueAndDocumented) {
  expectUniqueDocumentedNames(ssm::safetyMapperFields(), "safety mapper");
  expectUniqueDocumentedNames(ssm::landmarkStreamFields(), "landmark filter");
  expectUniqueDocumentedNames(ssm::disparityPipelineFields(), "disparity pipeline");
  expectUniqueDocumentedNames(ssm::stereoFrameProcessorFields(), "offline core");
  expectUniqueDocumentedNames(ssm::obstacleDetectionFields(), "obstacle detection");
  expectUniqueDocumentedNames(ssm::occupancyGrid2DFields(), "occupancy grid 2d");
  expectUniqueDocumentedNames(ssm::laserGridFields(), "laser grid");
  expectUniqueDocumentedNames(ssm::hybridSafetyMapFields(), "hybrid safety map");
}

TEST(CoreFieldLists, RangesAreWhatValidateAccepts) {
  expectRangesMatchValidation(ssm::safetyMapperFields(), "safety mapper");
  expectRangesMatchValidation(ssm::landmarkStreamFields(), "landmark filter");
  expectRangesMatchValidation(ssm::disparityPipelineFields(), "disparity pipeline");
  // Not the offline list: loadCoreParams validates with StereoFrameProcessorConfig::validate(),
  // which checks the pipeline's own limits only (texture_min_energy 2000 is accepted offline, the
  // disparity nodelet refuses it), as it always has.
  expectRangesMatchValidation(ssm::obstacleDetectionFields(), "obstacle detection");
  expectRangesMatchValidation(ssm::occupancyGrid2DFields(), "occupancy grid 2d");
  expectRangesMatchValidation(ssm::laserGridFields(), "laser grid");
  expectRangesMatchValidation(ssm::hybridSafetyMapFields(), "hybrid safety map");
}

TEST(CoreFieldLists, AccessorsRoundTrip) {
  expectAccessorsRoundTrip(ssm::safetyMapperFields(), "safety mapper");
  expectAccessorsRoundTrip(ssm::landmarkStreamFields(), "landmark filter");
  expectAccessorsRoundTrip(ssm::disparityPipelineFields(), "disparity pipeline");
  expectAccessorsRoundTrip(ssm::stereoFrameProcessorFields(), "offline core");
  expectAccessorsRoundTrip(ssm::obstacleDetectionFields(), "obstacle detection");
  expectAccessorsRoundTrip(ssm::occupancyGrid2DFields(), "occupancy grid 2d");
  expectAccessorsRoundTrip(ssm::laserGridFields(), "laser grid");
  expectAccessorsRoundTrip(ssm::hybridSafetyMapFields(), "hybrid safety map");
}

TEST(CoreFieldLists, TheOfflineListIsTheNodeletsCoreLists) {
  // loadCoreParams / setCoreParam read what the two nodelets read into the core.
  std::vector<std::string> expected = ssm::safetyMapperFields().names();
  expected.push_back("disparity_step");
  for (const std::string& n : ssm::rowGapFillFields().names())
    expected.push_back(n);
  // Offline only: the disparity nodelet publishes the coarse fill's readings merged, so the
  // safety-map nodelet cannot keep them apart (StereoFrameProcessorConfig::coarse_free_space).
  expected.push_back("coarse_free_space");
  for (const std::string& n : ssm::landmarkStreamFields().names())
    expected.push_back(n);
  for (const std::string& n : ssm::disparityPipelineFields().names())
    expected.push_back(n);
  EXPECT_EQ(ssm::stereoFrameProcessorFields().names(), expected);
}

TEST(CoreFieldLists, TheTextureWindowFollowsTheBlockSize) {
  const auto& l = ssm::disparityPipelineFields();
  ssm::DisparityPipelineConfig c;
  EXPECT_EQ(l.find("texture_window_size")->get(c), ParamValue(0));
  ASSERT_EQ(l.find("block_size")->set(&c, ParamValue(15)), "");
  EXPECT_EQ(c.texture.window_size, 15);
  ASSERT_EQ(l.find("texture_window_size")->set(&c, ParamValue(5)), "");
  EXPECT_EQ(c.texture.window_size, 5);
  ASSERT_EQ(l.find("block_size")->set(&c, ParamValue(11)), "");
  EXPECT_EQ(c.texture.window_size, 5) << "an explicit texture window stays";
  ASSERT_EQ(l.find("texture_window_size")->set(&c, ParamValue(0)), "");
  EXPECT_EQ(c.texture.window_size, 11);
  EXPECT_EQ(l.find("matcher")->set(&c, ParamValue(std::string("census"))),
            "matcher = 'census' must be 'bm' (StereoBM) or 'sgbm' (StereoSGBM)");
}

TEST(CoreFieldLists, LevelsAreTheReconfigureLevels) {
  for (const auto& f : ssm::safetyMapperFields().fields()) {
    const uint32_t l = f.info.level;
    EXPECT_TRUE(l == 0 || l == ssm::SafetyMapLevel::kStage || l == ssm::SafetyMapLevel::kGrid)
        << f.info.name;
  }
  for (const auto& f : ssm::disparityPipelineFields().fields()) {
    const uint32_t l = f.info.level;
    EXPECT_TRUE(l == 0 || l == ssm::DisparityLevel::kMatcher || l == ssm::DisparityLevel::kFilter)
        << f.info.name;
  }
  // The grid's sensor model is what a grid reset is for (README, dynamic_reconfigure).
  for (const char* name : {"incr_high", "incr_low", "decr", "occ_threshold"})
    EXPECT_EQ(ssm::safetyMapperFields().find(name)->info.level, ssm::SafetyMapLevel::kGrid);
}

}  // namespace
