// Tests of the open-world run (dataset/open_world.h) on a short procedural scene: the camera tilt
// measure (SceneScore::tilt_used / tilt_reported) reads back the unreported chassis tilt the
// degradation put into the true pose, on the right axis and with its sign, and a variant that
// does not re-level uses the reported pose.
#include "stereo_safety_map/dataset/open_world.h"

#include "stereo_safety_map/dataset/degradation.h"
#include "stereo_safety_map/dataset/procedural_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace ds = stereo_safety_map::dataset;

namespace {

struct TiltMeans {
  int frames = 0;
  double pitch_bias = 0.0, roll_bias = 0.0, pitch_rms = 0.0, roll_rms = 0.0;
};

TiltMeans means(const ds::SceneScore::TiltError& e, int n) {
  TiltMeans t;
  t.frames = n;
  if (n <= 0) return t;
  t.pitch_bias = e.pitch / n;
  t.roll_bias = e.roll / n;
  t.pitch_rms = std::sqrt(e.pitch2 / n);
  t.roll_rms = std::sqrt(e.roll2 / n);
  return t;
}

// Dev seed 1's scene, its first frames, with only a constant chassis tilt as degradation.
ds::SceneScore runWithTilt(double pitch_deg, double roll_deg, bool relevel = false) {
  ds::ProceduralScene scene;
  EXPECT_EQ(ds::generateProceduralScene(1, ds::ProceduralConfig(), &scene), "");
  ds::DegradationConfig d = ds::DegradationConfig::none();
  d.chassis_pitch_offset_deg = pitch_deg;
  d.chassis_roll_offset_deg = roll_deg;
  std::vector<ds::OpenWorldVariant> variants(1);
  variants[0].name = "default";  // relevel off: the map uses the reported pose
  if (relevel) {
    // Each frame re-levelled on the base's level plane within 2.5 m (FrameLevellingConfig).
    variants[0].config.mapper.relevel.enabled = true;
    variants[0].config.mapper.relevel.near_radius = 2.5;
  }
  ds::OpenWorldRunOptions options;
  options.max_frames = 12;
  const ds::OpenWorldSceneResult r = ds::runOpenWorldScene(scene, d, variants, options);
  EXPECT_EQ(r.error, "");
  EXPECT_EQ(r.scores.size(), 1u);
  return r.scores.empty() ? ds::SceneScore() : r.scores[0];
}

}  // namespace

TEST(OpenWorldTilt, AFrontDippingChassisReadsAsPositivePitch) {
  const ds::SceneScore s = runWithTilt(1.0, 0.0);
  ASSERT_GT(s.tilt_frames, 0);
  const TiltMeans rep = means(s.tilt_reported, s.tilt_frames);
  EXPECT_NEAR(rep.pitch_bias, 1.0, 0.02);
  EXPECT_NEAR(rep.pitch_rms, 1.0, 0.02);
  EXPECT_NEAR(rep.roll_bias, 0.0, 0.02);
  // Without re-levelling the pose the map used is the reported one.
  const TiltMeans used = means(s.tilt_used, s.tilt_frames);
  EXPECT_DOUBLE_EQ(used.pitch_bias, rep.pitch_bias);
  EXPECT_DOUBLE_EQ(used.roll_rms, rep.roll_rms);
}

TEST(OpenWorldTilt, ARollIsNotReadAsPitch) {
  const ds::SceneScore s = runWithTilt(0.0, -0.7);
  ASSERT_GT(s.tilt_frames, 0);
  const TiltMeans rep = means(s.tilt_reported, s.tilt_frames);
  EXPECT_NEAR(rep.roll_bias, -0.7, 0.02);  // positive = the left side rises
  EXPECT_NEAR(rep.roll_rms, 0.7, 0.02);
  EXPECT_NEAR(rep.pitch_bias, 0.0, 0.02);
}

TEST(OpenWorldTilt, APerfectPoseHasNoTiltError) {
  const ds::SceneScore s = runWithTilt(0.0, 0.0);
  ASSERT_GT(s.tilt_frames, 0);
  const TiltMeans rep = means(s.tilt_reported, s.tilt_frames);
  EXPECT_NEAR(rep.pitch_rms, 0.0, 1e-3);
  EXPECT_NEAR(rep.roll_rms, 0.0, 1e-3);
}

TEST(OpenWorldTilt, ReLevellingOnTheRobotsGroundRemovesMostOfAConstantPitch) {
  const ds::SceneScore s = runWithTilt(1.0, 0.0, true);
  ASSERT_GT(s.tilt_frames, 0);
  const TiltMeans rep = means(s.tilt_reported, s.tilt_frames);
  const TiltMeans used = means(s.tilt_used, s.tilt_frames);
  EXPECT_NEAR(rep.pitch_bias, 1.0, 0.02);
  EXPECT_LT(std::abs(used.pitch_bias), 0.3);
  EXPECT_LT(used.pitch_rms, 0.4);
}
