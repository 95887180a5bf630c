// Real-data check of the evaluation (docs/evaluation.md): each real rectified pair in
// ../shared/data/real/ goes through the core pipeline in single-frame mode (real_pair_check.h).
// The dominant ground plane recovered from the safety map must put the camera at the height and
// tilt given in that folder's README (a check of the pose estimate), and the map is scored against
// the hand labels of test/data/real_labels/ (image_labels.h). The scores are printed, not asserted
// against thresholds: seven hand-labelled frames measure the pipeline, they do not tune it. The
// label files are checked without the data; the rest is skipped when the folder is missing (a
// user's clone does not have it).
#include "stereo_safety_map/core/image_labels.h"
#include "stereo_safety_map/core/real_pair_check.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <sys/stat.h>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

#ifndef SSM_REAL_DATA_DIR
#define SSM_REAL_DATA_DIR "../shared/data/real"
#endif
#ifndef SSM_SOURCE_DIR
#define SSM_SOURCE_DIR "."
#endif

bool isDir(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

const std::string kRtabmap = std::string(SSM_REAL_DATA_DIR) + "/indoor_robot_rtabmap";
const std::string kBumblebee = std::string(SSM_REAL_DATA_DIR) + "/bumblebee2_boofcv";
const std::string kLabels = std::string(SSM_SOURCE_DIR) + "/test/data/real_labels";

// Tolerances of the check: "within a few cm and a degree" of the README's reference values.
constexpr double kHeightTolerance = 0.05;  // [m]
constexpr double kTiltTolerance = 1.0;     // [deg]

struct Reference {
  const char* frame;
  double height;  // [m]
  double pitch;   // [deg]
};

class RealData : public ::testing::TestWithParam<Reference> {};

// The pose of the camera above the map's dominant plane against the README's reference (an
// independent RANSAC on SGBM disparity). Whether that plane's cells are Level is not asserted: the
// camera is levelled on that same plane, so it would be circular; the hand labels below test the
// map.
TEST_P(RealData, IndoorCameraHeightAndTilt) {
  if (!isDir(kRtabmap)) GTEST_SKIP() << "skipped: real data not present";
  const Reference ref = GetParam();
  StereoCameraModel camera;
  ASSERT_EQ(loadStereoCalibration(kRtabmap + "/stereo_left.yaml", kRtabmap + "/stereo_right.yaml",
                                  &camera),
            "");
  EXPECT_NEAR(camera.baseline, 0.1197, 1e-3);
  const cv::Mat left = cv::imread(kRtabmap + "/left/" + ref.frame + ".jpg", cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(kRtabmap + "/right/" + ref.frame + ".jpg", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(left.empty());
  ASSERT_FALSE(right.empty());

  RealPairResult r;
  ASSERT_TRUE(checkRealPair(left, right, camera, RealPairCheckConfig(), &r)) << r.error;
  std::printf(
      "frame %s: %zu points; bootstrap %.3f m / %.2f deg; map plane %.3f m / %.2f deg "
      "(roll %.2f, %d cells, %s); level %d inclined %d non-ground %d cells\n",
      ref.frame, r.points, r.bootstrap.camera_height, r.bootstrap.pitch_deg,
      r.map_plane.camera_height, r.map_plane.pitch_deg, r.map_plane.roll_deg, r.map_plane.cells,
      toString(r.map_plane.label), r.level_cells, r.inclined_cells, r.non_ground_cells);
  ASSERT_TRUE(r.map_plane.found);
  EXPECT_NEAR(r.map_plane.camera_height, ref.height, kHeightTolerance);
  EXPECT_NEAR(r.map_plane.pitch_deg, ref.pitch, kTiltTolerance);
  EXPECT_GT(r.map_plane.cells, 50);
}

// 000-independent reference: RANSAC on SGBM disparity (../shared/data/real/README.md).
INSTANTIATE_TEST_SUITE_P(Rtabmap, RealData,
                         ::testing::Values(Reference{"50", 1.107, 3.8},
                                           Reference{"60", 1.095, 6.2}),
                         [](const ::testing::TestParamInfo<Reference>& info) {
                           return std::string("frame") + info.param.frame;
                         });

// ---------------------------------------------------------------------------------------------
// Hand labels (test/data/real_labels/README.md)

struct LabelledPair {
  const char* set;
  const char* name;
  bool has_floor;     // stones01 shows no drivable ground
  bool has_overhang;  // chair01's table
};

const LabelledPair kLabelledPairs[] = {
    {"indoor_robot_rtabmap", "50", true, false},    {"indoor_robot_rtabmap", "60", true, false},
    {"bumblebee2_boofcv", "chair01", true, true},   {"bumblebee2_boofcv", "chair02", true, false},
    {"bumblebee2_boofcv", "garden02", true, false}, {"bumblebee2_boofcv", "stones01", false, false},
    {"bumblebee2_boofcv", "wall01", true, false},
};

std::string labelFile(const LabelledPair& p) {
  return kLabels + "/" + p.set + "/" + p.name + ".txt";
}

// Every committed label file parses, is of the 640 x 480 left image, and labels floor (where the
// image shows some) and at least one unsafe class. Needs no real data.
TEST(RealLabels, EveryLabelFileParsesAndLabelsTheImage) {
  for (const LabelledPair& p : kLabelledPairs) {
    ImageLabels labels;
    ASSERT_EQ(loadImageLabels(labelFile(p), &labels), "");
    EXPECT_EQ(labels.width, 640) << labelFile(p);
    EXPECT_EQ(labels.height, 480) << labelFile(p);
    cv::Mat img;
    ASSERT_EQ(rasteriseImageLabels(labels, &img), "");
    auto count = [&](ImageLabel l) { return cv::countNonZero(img == static_cast<int>(l)); };
    const int unsafe =
        count(ImageLabel::kObstacle) + count(ImageLabel::kOverhang) + count(ImageLabel::kDropOff);
    std::printf(
        "%s/%s: %d polygons; pixels floor %d, obstacle %d, overhang %d, drop_off %d, "
        "ignore %d, unlabelled %d\n",
        p.set, p.name, static_cast<int>(labels.polygons.size()), count(ImageLabel::kFloor),
        count(ImageLabel::kObstacle), count(ImageLabel::kOverhang), count(ImageLabel::kDropOff),
        count(ImageLabel::kIgnore), count(ImageLabel::kNone));
    EXPECT_EQ(count(ImageLabel::kFloor) > 0, p.has_floor) << labelFile(p);
    EXPECT_EQ(count(ImageLabel::kOverhang) > 0, p.has_overhang) << labelFile(p);
    EXPECT_GT(unsafe, 0) << labelFile(p);
  }
}

// Every pair is scored against its labels: each labelled class gets pixels with a valid disparity,
// cells get a truth, the map classifies some of them. The scores are printed (the README's
// numbers come from evaluate_real_pairs), not asserted.
TEST(RealLabels, ScoresEveryPairAgainstItsLabels) {
  if (!isDir(kRtabmap) || !isDir(kBumblebee)) GTEST_SKIP() << "skipped: real data not present";
  StereoCameraModel rtabmap, bumblebee;
  ASSERT_EQ(loadStereoCalibration(kRtabmap + "/stereo_left.yaml", kRtabmap + "/stereo_right.yaml",
                                  &rtabmap),
            "");
  ASSERT_EQ(loadRectifiedCalibText(kBumblebee + "/rectified_calib.txt", 640, 480, &bumblebee), "");
  const RealPairCheckConfig config;
  const LabelScoringConfig scoring = LabelScoringConfig::forGrid(
      config.processor.mapper.grid.min_range, config.processor.mapper.grid.max_range);
  for (const LabelledPair& p : kLabelledPairs) {
    const bool indoor = std::string(p.set) == "indoor_robot_rtabmap";
    const std::string left_path = indoor ? kRtabmap + "/left/" + p.name + ".jpg"
                                         : kBumblebee + "/" + p.name + "_left_rect.png";
    const std::string right_path = indoor ? kRtabmap + "/right/" + p.name + ".jpg"
                                          : kBumblebee + "/" + p.name + "_right_rect.png";
    const cv::Mat left = cv::imread(left_path, cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(right_path, cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(left.empty()) << left_path;
    ASSERT_FALSE(right.empty()) << right_path;
    const StereoCameraModel& camera = indoor ? rtabmap : bumblebee;
    RealPairResult r;
    ASSERT_TRUE(checkRealPair(left, right, camera, config, &r)) << p.name << ": " << r.error;
    ASSERT_EQ(r.disparity.size(), left.size());

    ImageLabels labels;
    ASSERT_EQ(loadImageLabels(labelFile(p), &labels), "");
    cv::Mat label_image;
    ASSERT_EQ(rasteriseImageLabels(labels, &label_image), "");
    ImageLabelScore s;
    ASSERT_EQ(scoreAgainstImageLabels(label_image, r.disparity, camera, r.T_fixed_camera, r.map,
                                      scoring, &s),
              "");
    const ErrorRates e0 = errorRates(s.exact), e1 = errorRates(s.tolerant);
    std::printf(
        "%s/%s: %d truth cells (%d beyond R_max), coverage %.1f %%, FN %.1f %%, FP %.1f "
        "%% (1 cell: FN %.1f %%, FP %.1f %%)\n",
        p.set, p.name, s.truth_cells, s.truth_cells_beyond, 100.0 * s.coverage(), 100.0 * e0.fn,
        100.0 * e0.fp, 100.0 * e1.fn, 100.0 * e1.fp);
    for (ImageLabel l :
         {ImageLabel::kFloor, ImageLabel::kObstacle, ImageLabel::kOverhang, ImageLabel::kDropOff}) {
      const LabelClassScore& c = s.classes[static_cast<int>(l)];
      if (c.pixels == 0) continue;
      std::printf(
          "  %-8s %7lu px, %7lu with disparity; %4d cells (%d beyond R_max): safe %d, "
          "Non-ground %d, Unknown %d; recall %.1f %% (1 cell %.1f %%)\n",
          toString(l), static_cast<unsigned long>(c.pixels),
          static_cast<unsigned long>(c.pixels_with_disparity), c.cells, c.cells_beyond, c.map_safe,
          c.map_non_ground, c.map_unknown, 100.0 * c.recall(), 100.0 * c.recallTolerant());
      // Stereo saw every labelled class (the labels are on textured enough surfaces).
      EXPECT_GT(c.pixels_with_disparity, 0u) << p.name << " " << toString(l);
      EXPECT_GT(c.cells + c.cells_beyond, 0) << p.name << " " << toString(l);
    }
    EXPECT_GT(s.truth_cells, 0) << p.name;
    EXPECT_GT(s.coverage(), 0.0) << p.name;
    // Counts are consistent: every examined truth cell is covered or left Unknown by the map.
    EXPECT_EQ(static_cast<std::uint64_t>(s.covered_cells), s.exact.classified()) << p.name;
    EXPECT_EQ(static_cast<std::uint64_t>(s.truth_cells),
              s.exact.classified() + s.exact.unclassified_in_map)
        << p.name;
    // The single-pair map is levelled on measured ground, never on the base's plane that a
    // footprint-only robot segment gets (GroundPlane::from_base; levelling on it returns the pose
    // guess: stones01 came out pitched 12 deg up). Then most truth cells are classified and the
    // floor, where labelled, is safe within one cell (2026-12-06: coverage >= 74 %, floor >= 89 %
    // on every pair; with the circular levelling chair02's floor was 14 % safe, stones01's
    // coverage 37 %).
    ASSERT_TRUE(r.map_plane.found) << p.name;
    ASSERT_GE(r.map_plane.segment, 0) << p.name;
    ASSERT_LT(r.map_plane.segment, static_cast<int>(r.map.segments.size())) << p.name;
    EXPECT_FALSE(r.map.segments[r.map_plane.segment].plane.from_base) << p.name;
    EXPECT_GE(s.coverage(), 0.6) << p.name;
    const LabelClassScore& floor = s.classes[static_cast<int>(ImageLabel::kFloor)];
    if (floor.cells > 0) {
      EXPECT_GE(floor.recallTolerant(), 0.8) << p.name;
    }
  }
}

}  // namespace
}  // namespace stereo_safety_map
