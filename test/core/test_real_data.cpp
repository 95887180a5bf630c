// Real-data check of the evaluation (docs/evaluation.md): each real rectified pair in
// ../shared/data/real/ goes through the core pipeline in single-frame mode (real_pair_check.h);
// the dominant ground plane recovered from the safety map must put the camera at the height and
// tilt given in that folder's README, and the floor must come out Level. Skipped when the folder
// is missing (a user's clone does not have it).
#include "stereo_safety_map/core/real_pair_check.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <sys/stat.h>
#include <cstdio>
#include <string>

namespace stereo_safety_map {
namespace {

#ifndef SSM_REAL_DATA_DIR
#define SSM_REAL_DATA_DIR "../shared/data/real"
#endif

bool isDir(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

const std::string kRtabmap = std::string(SSM_REAL_DATA_DIR) + "/indoor_robot_rtabmap";
const std::string kBumblebee = std::string(SSM_REAL_DATA_DIR) + "/bumblebee2_boofcv";

// Tolerances of the check: "within a few cm and a degree" of the README's reference values.
constexpr double kHeightTolerance = 0.05;  // [m]
constexpr double kTiltTolerance = 1.0;     // [deg]

struct Reference {
  const char* frame;
  double height;  // [m]
  double pitch;   // [deg]
};

class RealData : public ::testing::TestWithParam<Reference> {};

TEST_P(RealData, IndoorFloorHeightTiltAndLevel) {
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
  EXPECT_EQ(r.map_plane.label, SafetyLabel::kLevel);
  EXPECT_GT(r.map_plane.cells, 50);
  EXPECT_GT(r.level_cells, 50);
}

// 000-independent reference: RANSAC on SGBM disparity (../shared/data/real/README.md).
INSTANTIATE_TEST_SUITE_P(Rtabmap, RealData,
                         ::testing::Values(Reference{"50", 1.107, 3.8},
                                           Reference{"60", 1.095, 6.2}),
                         [](const ::testing::TestParamInfo<Reference>& info) {
                           return std::string("frame") + info.param.frame;
                         });

// The Bumblebee pairs have no reference pose; the indoor ones must still give a Level floor
// below the camera.
TEST(RealDataBumblebee, IndoorCarpetIsLevelGroundBelowTheCamera) {
  if (!isDir(kBumblebee)) GTEST_SKIP() << "skipped: real data not present";
  StereoCameraModel camera;
  ASSERT_EQ(loadRectifiedCalibText(kBumblebee + "/rectified_calib.txt", 640, 480, &camera), "");
  for (const char* scene : {"chair01", "chair02"}) {
    const cv::Mat left =
        cv::imread(kBumblebee + "/" + scene + "_left_rect.png", cv::IMREAD_GRAYSCALE);
    const cv::Mat right =
        cv::imread(kBumblebee + "/" + scene + "_right_rect.png", cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(left.empty()) << scene;
    RealPairResult r;
    ASSERT_TRUE(checkRealPair(left, right, camera, RealPairCheckConfig(), &r))
        << scene << ": " << r.error;
    std::printf("%s: map plane %.3f m / %.2f deg (%d cells, %s)\n", scene,
                r.map_plane.camera_height, r.map_plane.pitch_deg, r.map_plane.cells,
                toString(r.map_plane.label));
    EXPECT_EQ(r.map_plane.label, SafetyLabel::kLevel) << scene;
    EXPECT_GT(r.map_plane.camera_height, 0.3) << scene;
    EXPECT_LT(r.map_plane.camera_height, 2.0) << scene;
  }
}

}  // namespace
}  // namespace stereo_safety_map
