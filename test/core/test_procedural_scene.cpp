// Tests of the procedural scene generator (dataset/procedural_scene.h): determinism, validity of
// 200 generated scenes (they load, their trajectories are clear, their GT starts on drivable
// ground), coverage of the hazard classes, floor kinds and the slopes near theta_T and theta_max
// (000 Alg. 2), the trajectory check on hand-made worlds whose answer is known, and the hazard
// class of GT cells on a hand-built scene.
#include "stereo_safety_map/dataset/procedural_scene.h"

#include "stereo_safety_map/dataset/portable_random.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

namespace ds = stereo_safety_map::dataset;
using stereo_safety_map::SafetyLabel;

namespace {

ds::SceneFile load(const std::string& yaml) {
  ds::SceneFile sf;
  const std::string e = ds::loadSceneFromString(yaml, "", &sf);
  EXPECT_EQ(e, "") << yaml;
  return sf;
}

// A 10 x 6 m floor at z = 0 with extra primitives and a trajectory from (0, 0) facing +x.
std::string world(const std::string& primitives, const std::string& steps) {
  return "name: t\nprimitives:\n  - {type: floor, name: base, min: [-3, -3], max: [7, 3]}\n" +
         primitives + "trajectory:\n  rate_hz: 10\n  start: [0, 0, 0]\n  speed: 0.5\n  steps:\n" +
         steps;
}

}  // namespace

TEST(ProceduralScene, HazardClassNames) {
  for (int i = 0; i < ds::kHazardClassCount; ++i) {
    const auto c = static_cast<ds::HazardClass>(i);
    ds::HazardClass back;
    ASSERT_TRUE(ds::parseHazardClass(ds::toString(c), &back));
    EXPECT_EQ(back, c);
  }
  EXPECT_STREQ(ds::toString(ds::HazardClass::kDropOff), "drop_off");
  EXPECT_STREQ(ds::toString(ds::HazardClass::kGentleRamp), "gentle_ramp");
  ds::HazardClass c;
  EXPECT_FALSE(ds::parseHazardClass("cliff", &c));
}

TEST(ProceduralScene, ConfigValidation) {
  EXPECT_EQ(ds::ProceduralConfig().validate(), "");
  EXPECT_EQ(ds::FootprintConfig().validate(), "");
  ds::ProceduralConfig c;
  c.min_items = 6;
  c.max_items = 5;
  EXPECT_NE(c.validate().find("min_items"), std::string::npos);
  c = ds::ProceduralConfig();
  c.speed_max = 0.1;
  EXPECT_NE(c.validate().find("speed"), std::string::npos);
  c = ds::ProceduralConfig();
  c.kind_weights["hovercraft"] = 1.0;
  EXPECT_NE(c.validate().find("hovercraft"), std::string::npos);
  c = ds::ProceduralConfig();
  c.kind_weights.clear();
  EXPECT_NE(c.validate().find("kind_weights"), std::string::npos);
  c = ds::ProceduralConfig();
  c.footprint.width = 0.0;
  EXPECT_NE(c.validate().find("footprint.width"), std::string::npos);
  c = ds::ProceduralConfig();
  c.slope_near_theta_t_weight = 0.7;
  EXPECT_NE(c.validate().find("slope_near"), std::string::npos);
  ds::ProceduralScene sc;
  EXPECT_NE(ds::generateProceduralScene(1, c, &sc), "");
  for (const std::string& k : ds::hazardKinds())
    EXPECT_EQ(ds::ProceduralConfig::defaultKindWeights().count(k), 1u);
}

TEST(ProceduralScene, PortableRandomNumbers) {
  ds::PortableRng a(42), b(42), c(43);
  double sum = 0.0, sum2 = 0.0, nsum = 0.0, nsum2 = 0.0;
  const int n = 200000;
  bool differ = false;
  for (int i = 0; i < n; ++i) {
    const double u = a.uniform();
    EXPECT_EQ(u, b.uniform());
    differ = differ || u != c.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
    sum2 += u * u;
    const double g = a.normal();
    b.normal();
    nsum += g;
    nsum2 += g * g;
  }
  EXPECT_TRUE(differ);
  EXPECT_NEAR(sum / n, 0.5, 0.005);
  EXPECT_NEAR(sum2 / n - 0.25, 1.0 / 12.0, 0.002);
  EXPECT_NEAR(nsum / n, 0.0, 0.01);
  EXPECT_NEAR(nsum2 / n, 1.0, 0.01);
  int hist[3] = {0, 0, 0};
  for (int i = 0; i < 3000; ++i)
    ++hist[a.integer(0, 2)];
  for (int h : hist)
    EXPECT_NEAR(h, 1000, 120);
}

TEST(ProceduralScene, SameSeedGivesTheSameYaml) {
  const ds::ProceduralConfig cfg;
  ds::ProceduralScene a, b, c;
  ASSERT_EQ(ds::generateProceduralScene(7, cfg, &a), "");
  ASSERT_EQ(ds::generateProceduralScene(7, cfg, &b), "");
  ASSERT_EQ(ds::generateProceduralScene(8, cfg, &c), "");
  EXPECT_EQ(a.yaml, b.yaml);  // byte-identical
  EXPECT_NE(a.yaml, c.yaml);
  EXPECT_EQ(a.seed, 7u);
  // The YAML is the scene: parsing it again gives the same solids and trajectory.
  const ds::SceneFile f = load(a.yaml);
  EXPECT_EQ(f.scene.primitives.size(), a.file.scene.primitives.size());
  EXPECT_EQ(f.scene.name, "procedural_7");
  EXPECT_EQ(f.trajectory.steps.size(), a.file.trajectory.steps.size());
  EXPECT_EQ(ds::sampleTrajectory(f.trajectory).size(),
            ds::sampleTrajectory(a.file.trajectory).size());
  EXPECT_FALSE(a.hazards.empty());
}

TEST(ProceduralScene, TwoHundredSeedsAreValidAndCoverTheHazards) {
  const ds::ProceduralConfig cfg;
  const ds::GroundTruthConfig gtc;
  std::set<ds::HazardClass> item_classes, cell_classes;
  std::set<std::string> floors, kinds;
  int near_theta_t = 0, near_theta_max = 0, below_h_t = 0, above_h_t = 0;
  int indoor = 0, with_back = 0, with_pause = 0, with_turn = 0, passes = 0;
  for (std::uint64_t seed = 0; seed < 200; ++seed) {
    ds::ProceduralScene sc;
    const std::string e = ds::generateProceduralScene(seed, cfg, &sc);
    ASSERT_EQ(e, "") << "seed " << seed;
    // The YAML loads and its trajectory passes the check on its own.
    const ds::SceneFile f = load(sc.yaml);
    ASSERT_EQ(ds::checkTrajectoryClear(f, cfg.footprint), "") << "seed " << seed;
    ASSERT_GE(sc.hazards.size(), static_cast<std::size_t>(cfg.min_items));
    ASSERT_LE(sc.hazards.size(), static_cast<std::size_t>(cfg.max_items));
    EXPECT_GE(sc.view_fraction, cfg.min_view_fraction);
    // ~12 s at 10 Hz, on the start level.
    EXPECT_EQ(ds::sampleTrajectory(f.trajectory).size(), 121u) << "seed " << seed;
    EXPECT_EQ(f.trajectory.base_z, 0.0);
    EXPECT_GE(f.camera.mount_z, cfg.mount_z_min);
    EXPECT_LE(f.camera.mount_z, cfg.mount_z_max);
    EXPECT_GE(f.camera.pitch_deg, cfg.pitch_min_deg);
    EXPECT_LE(f.camera.pitch_deg, cfg.pitch_max_deg);
    EXPECT_EQ(f.camera.width, 640);
    for (const ds::TrajectoryStep& s : f.trajectory.steps) {
      if (s.kind == ds::TrajectoryStep::Kind::kGo || s.kind == ds::TrajectoryStep::Kind::kBack) {
        EXPECT_GE(s.speed, cfg.speed_min);
        EXPECT_LE(s.speed, cfg.speed_max);
      }
    }
    bool back = false, pause = false, turn = false;
    for (const ds::TrajectoryStep& s : f.trajectory.steps) {
      back = back || s.kind == ds::TrajectoryStep::Kind::kBack;
      pause = pause || (s.kind == ds::TrajectoryStep::Kind::kPause && s.value >= 0.5);
      turn = turn || s.kind == ds::TrajectoryStep::Kind::kTurnBy;
    }
    with_back += back;
    with_pause += pause;
    with_turn += turn;
    indoor += sc.indoor;
    floors.insert(sc.floor_kind);
    for (const ds::HazardItem& h : sc.hazards) {
      item_classes.insert(h.cls);
      kinds.insert(h.kind);
      EXPECT_GE(h.clearance, cfg.min_clearance - 1e-9) << h.group;
      EXPECT_GE(h.frames_seen, cfg.min_item_frames) << h.group;
      EXPECT_EQ(h.group.compare(0, 1, "h"), 0);
      const bool sloped =
          h.kind == "ramp_up" || h.kind == "ramp_down" || h.kind.compare(0, 8, "curb_cut") == 0;
      if (sloped) {
        near_theta_t += std::abs(h.size - gtc.theta_t_deg) <= 2.0;
        near_theta_max += std::abs(h.size - gtc.theta_max_deg) <= 2.0;
        EXPECT_EQ(h.cls, h.size > gtc.theta_max_deg ? ds::HazardClass::kSteepRamp
                                                    : ds::HazardClass::kGentleRamp);
      }
      if (h.kind == "curb_down" || h.kind == "curb_up" || h.kind == "step_down" ||
          h.kind == "step_up") {
        (h.size < gtc.h_t ? below_h_t : above_h_t) += 1;
        EXPECT_GE(h.size, 0.03 - 1e-9);
        EXPECT_LE(h.size, 0.20 + 1e-9);
      }
      if (h.group_kind == "pole" || h.group_kind == "legs" || h.group_kind == "low" ||
          h.group_kind == "overhang")
        passes += h.clearance >= cfg.pass_clearance_min && h.clearance <= cfg.pass_clearance_max;
      // Every ground part is an entry of the scene.
      for (const ds::HazardPart& part : h.parts) {
        bool found = false;
        for (const ds::Primitive& p : f.scene.primitives)
          found = found || (p.group == part.entry && p.ground);
        EXPECT_TRUE(found) << part.entry;
      }
    }
    // Every 5th scene: the GT starts on drivable ground, the robot stays on Level cells, and the
    // hazard classes of the cells.
    if (seed % 5 == 0) {
      ds::GroundTruthMap gt;
      ASSERT_EQ(ds::computeGroundTruth(f.scene, gtc, {0.0, 0.0}, &gt), "") << "seed " << seed;
      for (const ds::RobotPose& p : ds::sampleTrajectory(f.trajectory))
        EXPECT_EQ(gt.labelAtPoint(p.x, p.y), SafetyLabel::kLevel) << "seed " << seed;
      const std::vector<ds::HazardClass> cls = ds::hazardClassMap(sc, gt, gtc);
      ASSERT_EQ(cls.size(), gt.labels.size());
      for (std::size_t k = 0; k < cls.size(); ++k) {
        cell_classes.insert(cls[k]);
        if (gt.obstacle[k]) {
          EXPECT_TRUE(cls[k] == ds::HazardClass::kObstacle || cls[k] == ds::HazardClass::kOverhang);
        }
      }
      EXPECT_EQ(cls[gt.index(gt.start_u, gt.start_v)], ds::HazardClass::kNone);
    }
  }
  for (int i = 1; i < ds::kHazardClassCount; ++i)
    EXPECT_TRUE(item_classes.count(static_cast<ds::HazardClass>(i)))
        << ds::toString(static_cast<ds::HazardClass>(i));
  for (int i = 0; i < ds::kHazardClassCount; ++i)
    EXPECT_TRUE(cell_classes.count(static_cast<ds::HazardClass>(i)))
        << ds::toString(static_cast<ds::HazardClass>(i));
  for (const std::string& k : ds::floorKinds())
    EXPECT_TRUE(floors.count(k)) << k;
  for (const std::string& k : ds::hazardKinds())
    EXPECT_TRUE(kinds.count(k)) << k;
  EXPECT_GE(near_theta_t, 20);
  EXPECT_GE(near_theta_max, 20);
  EXPECT_GE(below_h_t, 10);  // both sides of h_T = 5 cm
  EXPECT_GE(above_h_t, 10);
  EXPECT_GT(indoor, 60);
  EXPECT_LT(indoor, 140);
  EXPECT_GT(with_back, 40);
  EXPECT_GT(with_pause, 60);
  EXPECT_GT(with_turn, 60);
  EXPECT_GT(passes, 50);
}

TEST(ProceduralScene, KindWeightsSelectTheHazards) {
  ds::ProceduralConfig cfg;
  cfg.kind_weights = {{"pole", 1.0}, {"curb_down", 1.0}};
  cfg.min_items = cfg.max_items = 2;
  for (std::uint64_t seed = 0; seed < 10; ++seed) {
    ds::ProceduralScene sc;
    ASSERT_EQ(ds::generateProceduralScene(seed, cfg, &sc), "");
    ASSERT_EQ(sc.hazards.size(), 2u);
    for (const ds::HazardItem& h : sc.hazards)
      EXPECT_TRUE(h.kind == "pole" || h.kind == "curb_down") << h.kind;
  }
}

TEST(TrajectoryCheck, ClearPathPasses) {
  const ds::SceneFile f = load(world("",
                                     "    - {go: [4, 0]}\n    - {turn_by: 90}\n"
                                     "    - {back: [4, -1]}\n"));
  EXPECT_EQ(ds::checkTrajectoryClear(f, ds::FootprintConfig()), "");
}

TEST(TrajectoryCheck, ThroughAPoleFails) {
  const std::string pole = "  - {type: pole, name: post, at: [2, 0], radius: 0.05, height: 1}\n";
  const ds::SceneFile f = load(world(pole, "    - {go: [4, 0]}\n"));
  const std::string e = ds::checkTrajectoryClear(f, ds::FootprintConfig());
  EXPECT_NE(e.find("'post'"), std::string::npos) << e;
  // Passing 0.1 m beside it is clear (0.35 m half width + 0.05 m radius + 0.1 m).
  const ds::SceneFile g = load(world(pole,
                                     "    - {go: [0, -0.5]}\n    - {turn_to: 0}\n"
                                     "    - {go: [4, -0.5]}\n"));
  EXPECT_EQ(ds::checkTrajectoryClear(g, ds::FootprintConfig()), "");
  // Reversing into it fails too.
  const ds::SceneFile h = load(world(pole, "    - {turn_to: 180}\n    - {back: [3, 0]}\n"));
  EXPECT_NE(ds::checkTrajectoryClear(h, ds::FootprintConfig()).find("'post'"), std::string::npos);
  // Turning in place next to it sweeps the footprint's corners over it: 0.8 m from base_link is
  // inside the 0.97 m corner radius of the front.
  const ds::SceneFile t =
      load(world("  - {type: pole, name: post, at: [0.3, 0.8], radius: 0.05, height: 1}\n",
                 "    - {turn_by: 90}\n"));
  EXPECT_NE(ds::checkTrajectoryClear(t, ds::FootprintConfig()).find("'post'"), std::string::npos);
}

TEST(TrajectoryCheck, OverACurbFails) {
  // The floor ends at x = 3, a street 15 cm lower beyond it.
  const std::string street =
      "  - {type: floor, name: street, min: [3, -3], max: [7, 3], z: -0.15}\n";
  const std::string yaml =
      "name: t\nprimitives:\n  - {type: floor, name: walk, min: [-3, -3], max: [3, 3]}\n" + street +
      "trajectory:\n  rate_hz: 10\n  start: [0, 0, 0]\n  steps:\n";
  // The footprint's front is 0.9 m ahead of base_link: stopping with it at 2.95 m is clear.
  EXPECT_EQ(ds::checkTrajectoryClear(load(yaml + "    - {go: [2.05, 0]}\n"), ds::FootprintConfig()),
            "");
  const std::string e =
      ds::checkTrajectoryClear(load(yaml + "    - {go: [2.15, 0]}\n"), ds::FootprintConfig());
  EXPECT_NE(e.find("'street'"), std::string::npos) << e;
  EXPECT_NE(e.find("curb, step, drop or ramp"), std::string::npos) << e;
  // A 3 cm step up is a step too (not the start level within 1 cm), and so is a ramp.
  const ds::SceneFile step =
      load(world("  - {type: platform, name: mat, min: [2, -1], max: [3, 1], z: 0.03}\n",
                 "    - {go: [2, 0]}\n"));
  EXPECT_NE(ds::checkTrajectoryClear(step, ds::FootprintConfig()).find("'mat'"), std::string::npos);
  const ds::SceneFile ramp =
      load(world("  - {type: ramp, name: r, from: [2, 0], to: [4, 0], width: 1.5, slope_deg: 5}\n",
                 "    - {go: [2, 0]}\n"));
  EXPECT_NE(ds::checkTrajectoryClear(ramp, ds::FootprintConfig()).find("'r'"), std::string::npos);
  // Driving off the end of the world: no ground.
  const ds::SceneFile edge = load(world("", "    - {go: [6.5, 0]}\n"));
  EXPECT_NE(ds::checkTrajectoryClear(edge, ds::FootprintConfig()).find("no ground"),
            std::string::npos);
}

TEST(TrajectoryCheck, HeightBand) {
  // A table top at 0.7 m over the path blocks (an overhang); at 1.6 m it is driven under; a
  // 1 cm mat (non-ground) is driven over.
  const std::string table =
      "  - {type: table, name: desk, center: [3, 0], size: [1.2, 1.6], height: HEIGHT, "
      "leg_inset: 0.0}\n";
  auto with = [&](const std::string& h) {
    std::string t = table;
    t.replace(t.find("HEIGHT"), 6, h);
    return load(world(t, "    - {go: [5, 0]}\n"));
  };
  EXPECT_NE(ds::checkTrajectoryClear(with("0.7"), ds::FootprintConfig()).find("desk_top"),
            std::string::npos);
  // The legs stand 0.8 m off the axis, outside the 0.35 m half width.
  EXPECT_EQ(ds::checkTrajectoryClear(with("1.6"), ds::FootprintConfig()), "");
  const ds::SceneFile mat = load(world(
      "  - {type: box, name: mat, base: [3, 0, 0], size: [1, 1, 0.01]}\n", "    - {go: [5, 0]}\n"));
  EXPECT_EQ(ds::checkTrajectoryClear(mat, ds::FootprintConfig()), "");
  // A narrower robot fits where the default one does not.
  const ds::SceneFile gap =
      load(world("  - {type: pole, name: a, at: [3, 0.38], radius: 0.05, height: 1}\n"
                 "  - {type: pole, name: b, at: [3, -0.38], radius: 0.05, height: 1}\n",
                 "    - {go: [5, 0]}\n"));
  EXPECT_NE(ds::checkTrajectoryClear(gap, ds::FootprintConfig()), "");
  ds::FootprintConfig narrow;
  narrow.width = 0.6;
  EXPECT_EQ(ds::checkTrajectoryClear(gap, narrow), "");
  narrow.width = -1.0;
  EXPECT_NE(ds::checkTrajectoryClear(gap, narrow).find("width"), std::string::npos);
}

TEST(HazardClassMap, HandBuiltScene) {
  ds::ProceduralScene sc;
  sc.yaml =
      "name: t\nprimitives:\n"
      "  - {type: floor, name: base, min: [-2, -3], max: [6, 3]}\n"
      "  - {type: floor, name: hz_street, min: [6, -3], max: [9, 3], z: -0.15}\n"
      "  - {type: platform, name: hz_step, min: [2, 1.5], max: [4, 3], z: 0.1, thickness: 0.2}\n"
      "  - {type: ramp, name: hz_steep, from: [2, -1], to: [3.5, -1], width: 1, slope_deg: 12}\n"
      "  - {type: ramp, name: hz_gentle, from: [2, -2.5], to: [3.5, -2.5], width: 1, "
      "slope_deg: 5}\n"
      "  - {type: pole, name: hz_pole, at: [0, 2], radius: 0.05, height: 1}\n"
      "  - {type: table, name: hz_table, center: [4.5, 0], size: [1, 1], height: 0.75, "
      "leg_radius: 0.02, leg_inset: 0.05}\n";
  sc.file = load(sc.yaml);
  ds::HazardItem street, step, ramps;
  street.parts = {{"hz_street", ds::HazardClass::kDropOff}};
  step.parts = {{"hz_step", ds::HazardClass::kStepUp}};
  ramps.parts = {{"hz_steep", ds::HazardClass::kSteepRamp},
                 {"hz_gentle", ds::HazardClass::kGentleRamp}};
  sc.hazards = {street, step, ramps};
  ds::GroundTruthMap gt;
  ASSERT_EQ(ds::computeGroundTruth(sc.file.scene, ds::GroundTruthConfig(), {0.0, 0.0}, &gt), "");
  const std::vector<ds::HazardClass> cls = ds::hazardClassMap(sc, gt);
  ASSERT_EQ(cls.size(), gt.labels.size());
  auto at = [&](double x, double y) { return cls[gt.index(gt.cellOf(x), gt.cellOf(y))]; };
  EXPECT_EQ(at(1.0, 0.0), ds::HazardClass::kNone);
  EXPECT_EQ(at(-1.5, -2.5), ds::HazardClass::kNone);
  EXPECT_EQ(at(7.5, 0.0), ds::HazardClass::kDropOff);
  EXPECT_EQ(at(3.0, 2.2), ds::HazardClass::kStepUp);
  EXPECT_EQ(at(2.8, -1.0), ds::HazardClass::kSteepRamp);
  EXPECT_EQ(at(2.8, -2.5), ds::HazardClass::kGentleRamp);
  EXPECT_EQ(at(0.0, 2.0), ds::HazardClass::kObstacle);
  EXPECT_EQ(at(4.5, 0.0), ds::HazardClass::kOverhang);     // under the middle of the top
  EXPECT_EQ(at(4.07, -0.43), ds::HazardClass::kObstacle);  // a leg (it wins over the top)
  // The GT agrees on what is unsafe there.
  EXPECT_EQ(gt.labelAtPoint(4.5, 0.0), SafetyLabel::kNonGround);
  EXPECT_EQ(gt.labelAtPoint(7.5, 0.0), SafetyLabel::kNonGround);  // 15 cm below: unreachable
  EXPECT_EQ(gt.labelAtPoint(2.8, -2.5), SafetyLabel::kInclined);
  // An inconsistent map gives all kNone.
  ds::GroundTruthMap empty;
  EXPECT_TRUE(ds::hazardClassMap(sc, empty).empty());
}
