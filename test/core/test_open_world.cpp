// Tests of the open-world run (dataset/open_world.h) on a short procedural scene: the camera tilt
// measure (SceneScore::tilt_used / tilt_reported) reads back the unreported chassis tilt the
// degradation put into the true pose, on the right axis and with its sign, and a variant that
// does not re-level uses the reported pose. And the "stuck" measure (reachableSafeArea): the
// safe ground a planner could reach from the robot's footprint.
#include "stereo_safety_map/dataset/open_world.h"

#include "stereo_safety_map/dataset/degradation.h"
#include "stereo_safety_map/dataset/open_world_scoring.h"
#include "stereo_safety_map/dataset/procedural_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace ds = stereo_safety_map::dataset;
using stereo_safety_map::SafetyLabel;
using stereo_safety_map::SafetyMap;

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
ds::SceneScore runWithTilt(double pitch_deg, double roll_deg, bool relevel = false,
                           int frames = 12) {
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
  options.max_frames = frames;
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

namespace {

// A 21 x 21 map of 0.1 m cells, all `fill`, with the robot's cell at its centre (cell 0, 0).
SafetyMap squareMap(SafetyLabel fill) {
  SafetyMap m;
  m.min_u = -10;
  m.min_v = -10;
  m.width = 21;
  m.height = 21;
  m.resolution = 0.1;
  m.robot_u = 0;
  m.robot_v = 0;
  m.labels.assign(21 * 21, fill);
  return m;
}

}  // namespace

TEST(OpenWorldStuck, AllLevelIsTheWholeMap) {
  const SafetyMap m = squareMap(SafetyLabel::kLevel);
  EXPECT_NEAR(ds::reachableSafeArea(m, 0.35), 21 * 21 * 0.01, 1e-9);
}

TEST(OpenWorldStuck, ARingOfNonGroundBoxesTheChairIn) {
  // Level inside a Non-ground ring at Chebyshev radius 3: the reachable cells are the 5 x 5
  // within it.
  SafetyMap m = squareMap(SafetyLabel::kLevel);
  for (int v = -3; v <= 3; ++v) {
    for (int u = -3; u <= 3; ++u) {
      if (std::max(std::abs(u), std::abs(v)) == 3)
        m.labels[m.index(u, v)] = SafetyLabel::kNonGround;
    }
  }
  EXPECT_NEAR(ds::reachableSafeArea(m, 0.35), 25 * 0.01, 1e-9);
  // Unknown is no way through either (a planner must not count on it), Inclined is.
  m.labels[m.index(3, 0)] = SafetyLabel::kUnknown;
  EXPECT_NEAR(ds::reachableSafeArea(m, 0.35), 25 * 0.01, 1e-9);
  m.labels[m.index(3, 0)] = SafetyLabel::kInclined;
  EXPECT_NEAR(ds::reachableSafeArea(m, 0.35), (21 * 21 - 24 + 1) * 0.01, 1e-9);
}

TEST(OpenWorldStuck, SafeGroundOutsideTheFootprintIsNotReachedWithoutAPath) {
  // The footprint (radius 0.35 m: cells within 3.5 cells of the centre) is Non-ground; the safe
  // ground beyond it is not reachable: the chair cannot move.
  SafetyMap m = squareMap(SafetyLabel::kLevel);
  for (int v = -4; v <= 4; ++v) {
    for (int u = -4; u <= 4; ++u)
      m.labels[m.index(u, v)] = SafetyLabel::kNonGround;
  }
  EXPECT_EQ(ds::reachableSafeArea(m, 0.35), 0.0);
  // One safe footprint cell at the footprint's edge that touches the outer ground reaches it.
  m.labels[m.index(3, 0)] = SafetyLabel::kLevel;
  m.labels[m.index(4, 0)] = SafetyLabel::kLevel;
  EXPECT_NEAR(ds::reachableSafeArea(m, 0.35), (21 * 21 - 81 + 2) * 0.01, 1e-9);
  // A robot segment of one cell (the default seed on a stray column) is not a way out.
  SafetyMap one = squareMap(SafetyLabel::kNonGround);
  one.labels[one.index(0, 0)] = SafetyLabel::kLevel;
  EXPECT_NEAR(ds::reachableSafeArea(one, 0.35), 0.01, 1e-9);
  // An inconsistent map reaches nothing.
  one.labels.pop_back();
  EXPECT_EQ(ds::reachableSafeArea(one, 0.35), 0.0);
}

TEST(OpenWorldStuck, GroundNeverSeenIsPassedThroughNotCounted) {
  // A chair at rest: Unknown blind zone in front of its footprint (cells u 4..6), Level ground
  // beyond it (u >= 7), the footprint itself Unknown (unseen: under the chair).
  SafetyMap m = squareMap(SafetyLabel::kUnknown);
  for (int v = -10; v <= 10; ++v) {
    for (int u = 7; u <= 10; ++u)
      m.labels[m.index(u, v)] = SafetyLabel::kLevel;
  }
  const double beyond = 21 * 4 * 0.01;
  EXPECT_EQ(ds::reachableSafeArea(m, 0.35), 0.0);
  // The camera never saw u <= 6: the chair is not stuck behind ground no map can know.
  std::vector<std::uint8_t> unseen(m.labels.size(), 0);
  for (int v = -10; v <= 10; ++v) {
    for (int u = -10; u <= 6; ++u)
      unseen[m.index(u, v)] = 1;
  }
  EXPECT_NEAR(ds::reachableSafeArea(m, 0.35, &unseen), beyond, 1e-9);
  // Seen but Unknown (a pale floor the matcher found nothing on) blocks: u = 5 seen.
  for (int v = -10; v <= 10; ++v)
    unseen[m.index(5, v)] = 0;
  EXPECT_EQ(ds::reachableSafeArea(m, 0.35, &unseen), 0.0);
  // Non-ground is never passed through, seen or not.
  for (int v = -10; v <= 10; ++v) {
    unseen[m.index(5, v)] = 1;
    m.labels[m.index(5, v)] = SafetyLabel::kNonGround;
  }
  EXPECT_EQ(ds::reachableSafeArea(m, 0.35, &unseen), 0.0);
  // A wrong-sized mask is ignored.
  m.labels[m.index(5, 0)] = SafetyLabel::kUnknown;
  EXPECT_NEAR(ds::reachableSafeArea(m, 0.35, &unseen), beyond, 1e-9);
  unseen.pop_back();
  EXPECT_EQ(ds::reachableSafeArea(m, 0.35, &unseen), 0.0);
}

TEST(OpenWorldStuck, TheScorerAsksOnlyMapsAfterTheGraceTime) {
  // Dev seed 1 with a perfect pose: no map of the first 2 s is asked; later ones are. (Its
  // pale tiles leave the chair stuck in its first maps after the grace time, Unknown all
  // around: the measure exists to show that, so the test does not assert a count.)
  const ds::SceneScore early = runWithTilt(0.0, 0.0, false, 12);
  EXPECT_EQ(early.maps_after_grace, 0);
  EXPECT_EQ(early.maps_stuck, 0);
  const ds::SceneScore s = runWithTilt(0.0, 0.0, false, 40);
  EXPECT_GT(s.maps_after_grace, 0);
  EXPECT_LE(s.maps_stuck, s.maps_after_grace);
}

// OpenWorldRunOptions::trace_cells: one line per traced cell and frame, with the cell's label and
// its column's log-odds; the floor 2 m ahead of the start is seen (some voxel of its column was
// hit or passed) by the last frame.
TEST(OpenWorldTrace, ACellIsFollowedFrameByFrame) {
  ds::ProceduralScene scene;
  ASSERT_EQ(ds::generateProceduralScene(1, ds::ProceduralConfig(), &scene), "");
  const auto& tr = scene.file.trajectory;
  const double yaw = tr.start_yaw_deg * M_PI / 180.0;
  ds::OpenWorldRunOptions options;
  options.max_frames = 6;
  options.image_dir = ::testing::TempDir() + "ow_trace_test";
  ASSERT_EQ(std::system(("mkdir -p " + options.image_dir).c_str()), 0);
  options.trace_cells.emplace_back(tr.start_x + 2.0 * std::cos(yaw),
                                   tr.start_y + 2.0 * std::sin(yaw));
  std::vector<ds::OpenWorldVariant> variants(1);
  variants[0].name = "traced";
  const ds::OpenWorldSceneResult r =
      ds::runOpenWorldScene(scene, ds::DegradationConfig::none(), variants, options);
  ASSERT_EQ(r.error, "");
  std::ifstream in(options.image_dir + "/seed1_trace.txt");
  ASSERT_TRUE(in.good());
  std::string line, last;
  int lines = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    ++lines;
    EXPECT_NE(line.find(" traced "), std::string::npos) << line;
    last = line;
  }
  EXPECT_EQ(lines, options.max_frames);
  // The last map holds the cell, classified or not, with its column after the '|'.
  ASSERT_EQ(last.find("outside"), std::string::npos) << last;
  const std::size_t bar = last.find('|');
  ASSERT_NE(bar, std::string::npos) << last;
  std::istringstream voxels(last.substr(bar + 1));
  std::string v;
  bool touched = false;
  while (voxels >> v)
    touched = touched || std::atoi(v.c_str()) != 0;
  EXPECT_TRUE(touched) << last;
}
