// Tests of the trajectory step `back:` (reversing without turning to face the target) and of the
// scene-file additions the procedural generator needs: convex polygon floors and sloped `slab`
// solids (curb-cut flares). Worlds whose answer is known by construction.
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ds = stereo_safety_map::dataset;

namespace {

ds::TrajectoryStep step(ds::TrajectoryStep::Kind kind, double x, double y, double value = 0.0) {
  ds::TrajectoryStep s;
  s.kind = kind;
  s.x = x;
  s.y = y;
  s.value = value;
  return s;
}

}  // namespace

TEST(Trajectory, BackDrivesBackwardsWithoutTurning) {
  ds::TrajectoryConfig t;
  t.rate_hz = 10.0;
  t.speed = 0.5;
  t.start_yaw_deg = 30.0;
  const double yaw = 30.0 * M_PI / 180.0;
  // 1 m straight behind the start: no turn, 2 s at 0.5 m/s.
  t.steps = {step(ds::TrajectoryStep::Kind::kBack, -std::cos(yaw), -std::sin(yaw))};
  ASSERT_EQ(t.validate(), "");
  EXPECT_NEAR(ds::trajectoryDuration(t), 2.0, 1e-9);
  const auto poses = ds::sampleTrajectory(t);
  ASSERT_EQ(poses.size(), 21u);
  for (const auto& p : poses) {
    EXPECT_NEAR(p.yaw, yaw, 1e-9);  // heading kept all along
    // On the line behind the start, at 0.5 m/s backwards.
    EXPECT_NEAR(p.x, -std::cos(yaw) * 0.5 * p.t, 1e-9);
    EXPECT_NEAR(p.y, -std::sin(yaw) * 0.5 * p.t, 1e-9);
  }
  EXPECT_NEAR(poses[10].v, -0.5, 1e-9);  // reversing: negative forward speed
  EXPECT_NEAR(poses[10].omega, 0.0, 1e-12);
}

TEST(Trajectory, BackTurnsTheRearTowardsATargetOffTheAxis) {
  ds::TrajectoryConfig t;
  t.turn_rate_deg = 45.0;
  t.speed = 1.0;
  // Target to the left (+y) of a robot facing +x: the rear (pointing -x) turns 90 deg to face
  // +y, i.e. the robot turns to yaw -90 deg, then reverses 2 m.
  t.steps = {step(ds::TrajectoryStep::Kind::kBack, 0.0, 2.0)};
  EXPECT_NEAR(ds::trajectoryDuration(t), 2.0 + 2.0, 1e-9);
  const ds::RobotPose end = ds::poseAt(t, 100.0);
  EXPECT_NEAR(end.x, 0.0, 1e-9);
  EXPECT_NEAR(end.y, 2.0, 1e-9);
  EXPECT_NEAR(end.yaw, -M_PI / 2.0, 1e-9);
  const ds::RobotPose mid = ds::poseAt(t, 3.0);  // 1 s into the reverse
  EXPECT_NEAR(mid.y, 1.0, 1e-9);
  EXPECT_NEAR(mid.v, -1.0, 1e-9);
  // A go to the same point turns the front to it instead.
  t.steps = {step(ds::TrajectoryStep::Kind::kGo, 0.0, 2.0)};
  EXPECT_NEAR(ds::poseAt(t, 100.0).yaw, M_PI / 2.0, 1e-9);
  EXPECT_GT(ds::poseAt(t, 3.0).v, 0.0);
}

TEST(Trajectory, BackThenGoReturnsToTheStart) {
  ds::TrajectoryConfig t;
  t.steps = {step(ds::TrajectoryStep::Kind::kGo, 2.0, 0.0),
             step(ds::TrajectoryStep::Kind::kBack, 1.0, 0.0),
             step(ds::TrajectoryStep::Kind::kPause, 0.0, 0.0, 1.0)};
  const auto poses = ds::sampleTrajectory(t);
  ASSERT_FALSE(poses.empty());
  double min_x_after_back = 10.0;
  for (const auto& p : poses) {
    EXPECT_NEAR(p.yaw, 0.0, 1e-12);  // never turns
    if (p.t > 5.0) min_x_after_back = std::min(min_x_after_back, p.x);
  }
  EXPECT_NEAR(poses.back().x, 1.0, 1e-9);
  EXPECT_NEAR(min_x_after_back, 1.0, 1e-9);
}

TEST(SceneLoader, ParsesBackSteps) {
  const std::string yaml =
      "name: t\nprimitives:\n  - {type: floor, min: [-5, -5], max: [5, 5]}\n"
      "trajectory:\n  rate_hz: 10\n  start: [0, 0, 0]\n  steps:\n"
      "    - {go: [2, 0]}\n    - {back: [1, 0], speed: 0.25}\n";
  ds::SceneFile sf;
  ASSERT_EQ(ds::loadSceneFromString(yaml, "", &sf), "");
  ASSERT_EQ(sf.trajectory.steps.size(), 2u);
  EXPECT_EQ(sf.trajectory.steps[1].kind, ds::TrajectoryStep::Kind::kBack);
  EXPECT_DOUBLE_EQ(sf.trajectory.steps[1].x, 1.0);
  EXPECT_DOUBLE_EQ(sf.trajectory.steps[1].speed, 0.25);
  // 2 m at the default 0.4 m/s, 1 m backwards at 0.25 m/s.
  EXPECT_NEAR(ds::trajectoryDuration(sf.trajectory), 5.0 + 4.0, 1e-9);
  // Two kinds in one step are an error naming `back`.
  const std::string bad =
      "name: t\nprimitives:\n  - {type: floor, min: [-5, -5], max: [5, 5]}\n"
      "trajectory:\n  steps:\n    - {go: [2, 0], back: [1, 0]}\n";
  const std::string e = ds::loadSceneFromString(bad, "", &sf);
  EXPECT_NE(e.find("back"), std::string::npos) << e;
}

TEST(SceneLoader, PolygonFloorsAndSlabs) {
  // A floor polygon (a trapezoid) and a sloped triangle (a curb-cut flare): 0 on two corners,
  // -0.15 at the third.
  const std::string yaml =
      "name: t\nprimitives:\n"
      "  - {type: floor, name: trap, polygon: [[0, 0], [4, 0], [3, 2], [1, 2]], z: 0.1}\n"
      "  - {type: slab, name: flare, top: [[10, 0, 0], [10, 1, -0.15], [9, 1, 0]], "
      "thickness: 0.2}\n";
  ds::SceneFile sf;
  ASSERT_EQ(ds::loadSceneFromString(yaml, "", &sf), "");
  ASSERT_EQ(sf.scene.primitives.size(), 2u);
  const ds::Primitive& trap = sf.scene.primitives[0];
  EXPECT_TRUE(trap.ground);
  EXPECT_EQ(trap.type, "floor");
  double z = 0.0;
  EXPECT_TRUE(trap.topHeightAt(2.0, 1.0, &z));
  EXPECT_NEAR(z, 0.1, 1e-12);
  EXPECT_FALSE(trap.topHeightAt(0.2, 1.8, &z));          // outside the slanted side
  EXPECT_NEAR(trap.bounds.min().z(), 0.1 - 0.3, 1e-12);  // default thickness
  const ds::Primitive& flare = sf.scene.primitives[1];
  EXPECT_TRUE(flare.ground);
  EXPECT_EQ(flare.topPolygon().size(), 3u);
  ASSERT_TRUE(flare.topHeightAt(9.9, 0.5, &z));
  // The plane through the 3 corners: z = -0.15 (x - 10) - 0.15 y.
  EXPECT_NEAR(z, -0.15 * (9.9 - 10.0) - 0.15 * 0.5, 1e-9);
  EXPECT_NEAR(flare.bounds.min().z(), -0.15 - 0.2, 1e-12);
  double g;
  EXPECT_TRUE(ds::groundHeightAt(sf.scene, 2.0, 0.5, &g));

  // Not convex, not planar, vertical, too few corners: errors naming the key.
  ds::SceneFile bad;
  EXPECT_NE(ds::loadSceneFromString(
                "name: t\nprimitives:\n  - {type: floor, polygon: [[0, 0], [4, 0], [2, 1], "
                "[4, 2], [0, 2]]}\n",
                "", &bad)
                .find("polygon"),
            std::string::npos);
  EXPECT_NE(ds::loadSceneFromString("name: t\nprimitives:\n  - {type: slab, top: [[0, 0, 0], "
                                    "[1, 0, 0], [1, 1, 0.5], [0, 1, 0]]}\n",
                                    "", &bad)
                .find("top"),
            std::string::npos);
  EXPECT_NE(ds::loadSceneFromString("name: t\nprimitives:\n  - {type: slab, top: [[0, 0, 0], "
                                    "[1, 0, 0], [1, 0, 1]]}\n",
                                    "", &bad)
                .find("top"),
            std::string::npos);
  EXPECT_NE(ds::loadSceneFromString(
                "name: t\nprimitives:\n  - {type: floor, polygon: [[0, 0], [4, 0]]}\n", "", &bad)
                .find("polygon"),
            std::string::npos);
}

TEST(SceneLoader, SlabFlareGroundTruthIsInclined) {
  // A 6 deg slab between two floors at 0 and -0.1 m: Inclined and reachable (000 Alg. 2).
  const double run = 0.1 / std::tan(6.0 * M_PI / 180.0);
  const std::string r = std::to_string(run);
  const std::string yaml =
      "name: t\nprimitives:\n"
      "  - {type: floor, min: [-2, -1], max: [0, 1]}\n"
      "  - {type: slab, top: [[0, -1, 0], [" +
      r + ", -1, -0.1], [" + r +
      ", 1, -0.1], [0, 1, 0]]}\n"
      "  - {type: floor, min: [" +
      r + ", -1], max: [4, 1], z: -0.1}\n";
  ds::SceneFile sf;
  ASSERT_EQ(ds::loadSceneFromString(yaml, "", &sf), "");
  ds::GroundTruthMap gt;
  ASSERT_EQ(ds::computeGroundTruth(sf.scene, ds::GroundTruthConfig(), {-1.0, 0.0}, &gt), "");
  EXPECT_EQ(gt.labelAtPoint(0.5, 0.0), stereo_safety_map::SafetyLabel::kInclined);
  EXPECT_EQ(gt.labelAtPoint(3.0, 0.0), stereo_safety_map::SafetyLabel::kLevel);
  EXPECT_NEAR(gt.slope_deg[gt.index(gt.cellOf(0.5), 0)], 6.0, 1e-4);  // float
}
