// Tests of the synthetic-dataset ground truth (GT safety map labels of 000 Sec. VI-VII on tiny
// hand-made scenes whose answer is known by construction), the scene file loader, and the
// repository's benchmark scenes.
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/scene_loader.h"

#include <gtest/gtest.h>

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace ds = stereo_safety_map::dataset;
using stereo_safety_map::SafetyLabel;

namespace {

// Scene from YAML primitives; the robot starts at (0, 0).
ds::SceneFile load(const std::string& primitives, const std::string& extra = "") {
  ds::SceneFile sf;
  const std::string yaml = "name: t\nprimitives:\n" + primitives + extra;
  const std::string e = ds::loadSceneFromString(yaml, "", &sf);
  EXPECT_EQ(e, "") << yaml;
  return sf;
}

ds::GroundTruthMap gt(const ds::SceneFile& sf, Eigen::Vector2d start = Eigen::Vector2d(0, 0)) {
  ds::GroundTruthMap m;
  const std::string e = ds::computeGroundTruth(sf.scene, ds::GroundTruthConfig(), start, &m);
  EXPECT_EQ(e, "");
  return m;
}

SafetyLabel at(const ds::GroundTruthMap& m, double x, double y) {
  return m.labelAtPoint(x, y);
}

// Upper floor x in [-2, 2] at z = 0, lower floor x in [2, 6] 15 cm lower (a curb down).
const char* kCurb =
    "  - {type: floor, name: upper, min: [-2, -2], max: [2, 2], z: 0}\n"
    "  - {type: floor, name: lower, min: [2, -2], max: [6, 2], z: -0.15}\n";

std::string tempDir() {
  char tmpl[] = "/tmp/gt_test_XXXXXX";
  const char* d = mkdtemp(tmpl);
  return d ? d : "";
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

TEST(GroundTruthConfig, DefaultsAreTheLabellersAndValidateNamesTheParameter) {
  const ds::GroundTruthConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_DOUBLE_EQ(c.theta_max_deg, 10.0);  // 000 Alg. 2
  EXPECT_DOUBLE_EQ(c.theta_t_deg, 3.0);
  EXPECT_DOUBLE_EQ(c.h_t, 0.05);
  EXPECT_DOUBLE_EQ(c.robot_height, 1.5);
  EXPECT_DOUBLE_EQ(c.resolution, 0.1);
  ds::GroundTruthConfig b = c;
  b.h_t = 0.0;
  EXPECT_NE(b.validate().find("h_t"), std::string::npos);
  b = c;
  b.theta_t_deg = 20.0;
  EXPECT_NE(b.validate().find("theta_t"), std::string::npos);
  b = c;
  b.resolution = std::nan("");
  EXPECT_NE(b.validate().find("resolution"), std::string::npos);
}

TEST(GroundTruth, FlatFloorIsLevelAndTheOutsideUnknown) {
  const auto m = gt(load("  - {type: floor, min: [-2, -1], max: [3, 1]}\n"));
  EXPECT_EQ(at(m, 0, 0), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 2.9, 0.9), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 3.3, 0), SafetyLabel::kUnknown);  // in the margin, no ground
  EXPECT_EQ(m.resolution, 0.1);
  EXPECT_NEAR(m.ground_height[m.index(10, 0)], 0.0, 1e-6);
  // The floor's border faces the unknown: potential drop-off edges; the interior does not.
  EXPECT_TRUE(m.drop_off[m.index(30, 0)]);
  EXPECT_FALSE(m.drop_off[m.index(0, 0)]);
}

TEST(GroundTruth, AreaBelowACurbIsNonGround) {
  const auto m = gt(load(kCurb));
  EXPECT_EQ(at(m, 0, 0), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 1.8, 0), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 2.3, 0), SafetyLabel::kNonGround);  // unreachable: 15 cm > h_T
  EXPECT_EQ(at(m, 5.0, 1.5), SafetyLabel::kNonGround);
  EXPECT_NEAR(m.ground_height[m.index(40, 0)], -0.15, 1e-6);
  // The curb's top edge is a drop-off edge, the cell behind it is not.
  EXPECT_TRUE(m.drop_off[m.index(20, 0)]);
  EXPECT_FALSE(m.drop_off[m.index(18, 0)]);
}

TEST(GroundTruth, LowerAreaReachedByAGentleRampIsSafe) {
  // The same curb, plus a 5 deg ramp from the upper floor down to the lower one.
  const double len = 0.15 / std::tan(5.0 * M_PI / 180.0);  // 1.71 m
  std::ostringstream ramp;
  ramp << std::setprecision(17)
       << "  - {type: floor, name: upper2, min: [-2, 2], max: [0.3, 4], z: 0}\n"
       << "  - {type: floor, name: lower2, min: [0.3, 2], max: [6, 4], z: -0.15}\n"
       << "  - {type: ramp, name: ramp, from: [0.3, 3], to: [" << 0.3 + len
       << ", 3], width: 2, z_from: 0, z_to: -0.15}\n";
  const auto m = gt(load(std::string(kCurb) + ramp.str()));
  EXPECT_EQ(at(m, 1.0, 3.0), SafetyLabel::kInclined);  // the ramp
  EXPECT_EQ(at(m, 4.0, 3.0), SafetyLabel::kLevel);     // the lower area behind it
  EXPECT_EQ(at(m, 4.0, 0.0), SafetyLabel::kLevel);     // and the part below the curb
  EXPECT_EQ(at(m, 0.0, 0.0), SafetyLabel::kLevel);
  // The ramp's slope and plane are the analytic ones.
  const auto planes = ds::groundTruthPlanes(load(std::string(kCurb) + ramp.str()).scene, m);
  bool found = false;
  for (const auto& p : planes) {
    if (p.name != "ramp") continue;
    found = true;
    EXPECT_NEAR(p.slope_deg, 5.0, 1e-9);
    EXPECT_NEAR(p.a, -std::tan(5.0 * M_PI / 180.0), 1e-9);
    EXPECT_NEAR(p.b, 0.0, 1e-12);
    EXPECT_NEAR(p.a * 0.3 + p.c, 0.0, 1e-9);  // z(from) = 0
    EXPECT_EQ(p.label, SafetyLabel::kInclined);
    EXPECT_EQ(p.polygon.size(), 4u);
    EXPECT_GT(p.cells, 100);
  }
  EXPECT_TRUE(found);
}

TEST(GroundTruth, BoxIsNonGroundAndTheFloorAroundItLevel) {
  const auto m =
      gt(load("  - {type: floor, min: [-2, -2], max: [4, 2]}\n"
              "  - {type: box, name: crate, base: [2, 0, 0], size: [0.6, 0.4, 0.5]}\n"));
  EXPECT_EQ(at(m, 2.0, 0.0), SafetyLabel::kNonGround);
  EXPECT_EQ(at(m, 2.25, 0.15), SafetyLabel::kNonGround);  // a corner cell
  EXPECT_EQ(at(m, 2.5, 0.0), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 2.0, 0.4), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 3.5, 0.0), SafetyLabel::kLevel);  // reached around the box
  const auto obs = ds::groundTruthObstacles(
      load("  - {type: floor, min: [-2, -2], max: [4, 2]}\n"
           "  - {type: box, name: crate, base: [2, 0, 0], size: [0.6, 0.4, 0.5], yaw_deg: 30}\n")
          .scene);
  ASSERT_EQ(obs.size(), 1u);
  EXPECT_EQ(obs[0].name, "crate");
  EXPECT_NEAR((obs[0].obb.center - Eigen::Vector3d(2, 0, 0.25)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((2.0 * obs[0].obb.half_size - Eigen::Vector3d(0.6, 0.4, 0.5)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(obs[0].obb.rotation(1, 0), std::sin(30.0 * M_PI / 180.0), 1e-12);
}

TEST(GroundTruth, LowTableTopIsAnOverhangAndAHighOneIsDrivenUnder) {
  const std::string floor = "  - {type: floor, min: [-2, -2], max: [4, 2]}\n";
  const auto low =
      gt(load(floor + "  - {type: table, center: [2, 0], size: [1.2, 0.8], height: 0.7}\n"));
  EXPECT_EQ(at(low, 2.0, 0.0), SafetyLabel::kNonGround);  // under the top, between the legs
  EXPECT_EQ(at(low, 1.5, 0.3), SafetyLabel::kNonGround);
  EXPECT_EQ(at(low, 2.0, 0.6), SafetyLabel::kLevel);
  const auto high =
      gt(load(floor + "  - {type: table, center: [2, 0], size: [1.2, 0.8], height: 2.0}\n"));
  EXPECT_EQ(at(high, 2.0, 0.0), SafetyLabel::kLevel);  // above robot height
  EXPECT_EQ(at(high, 1.5, 0.0), SafetyLabel::kLevel);
  // Its legs still stand on the floor: inset 0.05 + radius 0.025 from the corners.
  EXPECT_EQ(at(high, 2.0 + 0.6 - 0.075, 0.4 - 0.075), SafetyLabel::kNonGround);
}

TEST(GroundTruth, SteepRampIsNonGroundAndSoIsWhatOnlyItReaches) {
  const auto m =
      gt(load("  - {type: floor, min: [-2, -2], max: [2, 2]}\n"
              "  - {type: ramp, name: steep, from: [2, 0], to: [3, 0], width: 2, z_from: 0, "
              "slope_deg: 15}\n"
              "  - {type: floor, name: top, min: [3, -2], max: [5, 2], z: 0.26795}\n"));
  EXPECT_EQ(at(m, 2.5, 0.0), SafetyLabel::kNonGround);  // 15 deg > theta_max
  EXPECT_EQ(at(m, 4.0, 0.0), SafetyLabel::kNonGround);  // unreachable
  EXPECT_NEAR(m.slope_deg[m.index(25, 0)], 15.0, 1e-3);
  // A 10 deg ramp (theta_max itself) is drivable: Inclined.
  const auto ok = gt(load(
      "  - {type: floor, min: [-2, -2], max: [2, 2]}\n"
      "  - {type: ramp, name: r10, from: [2, 0], to: [3, 0], width: 2, z_from: 0, slope_deg: 9.9}\n"
      "  - {type: floor, name: top, min: [3, -2], max: [5, 2], z: 0.17453}\n"));
  EXPECT_EQ(at(ok, 2.5, 0.0), SafetyLabel::kInclined);
  EXPECT_EQ(at(ok, 4.0, 0.0), SafetyLabel::kLevel);
  // A 2 deg ramp is Level (<= theta_T).
  const auto flat =
      gt(load("  - {type: floor, min: [-2, -2], max: [2, 2]}\n"
              "  - {type: ramp, from: [2, 0], to: [4, 0], width: 2, z_from: 0, slope_deg: -2}\n"));
  EXPECT_EQ(at(flat, 3.0, 0.0), SafetyLabel::kLevel);
}

TEST(GroundTruth, StepsBelowHtAreDrivableAndAboveAreNot) {
  const auto m =
      gt(load("  - {type: floor, min: [-2, -2], max: [2, 2]}\n"
              "  - {type: steps, name: low, from: [2, -1], direction_deg: 0, width: 2, count: 2, "
              "rise: 0.04, run: 1.0}\n"
              "  - {type: steps, name: high, from: [2, 1], direction_deg: 0, width: 2, count: 2, "
              "rise: -0.15, run: 1.0}\n"));
  EXPECT_EQ(at(m, 2.5, -1.0), SafetyLabel::kLevel);     // 4 cm up
  EXPECT_EQ(at(m, 3.5, -1.0), SafetyLabel::kLevel);     // another 4 cm up
  EXPECT_EQ(at(m, 2.5, 1.5), SafetyLabel::kNonGround);  // 15 cm down
  EXPECT_EQ(at(m, 3.5, 1.5), SafetyLabel::kNonGround);  // and further down
  EXPECT_NEAR(m.ground_height[m.index(35, 15)], -0.30, 1e-6);
}

TEST(GroundTruth, WallsBlockReachability) {
  const auto m =
      gt(load("  - {type: floor, min: [-2, -2], max: [4, 2]}\n"
              "  - {type: wall, from: [1, -2.5], to: [1, 2.5], height: 2.0}\n"));
  EXPECT_EQ(at(m, 0.5, 0.0), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 1.0, 0.0), SafetyLabel::kNonGround);
  EXPECT_EQ(at(m, 2.0, 0.0), SafetyLabel::kNonGround);  // same height but unreachable
  // A thin pole is caught even though it misses every cell centre.
  const auto p =
      gt(load("  - {type: floor, min: [-2, -2], max: [4, 2]}\n"
              "  - {type: pole, at: [1.03, 0.53], radius: 0.015, height: 1.0}\n"));
  EXPECT_EQ(at(p, 1.0, 0.5), SafetyLabel::kNonGround);
  EXPECT_EQ(at(p, 1.2, 0.5), SafetyLabel::kLevel);
}

TEST(GroundTruth, RelabelWithAPlanningRadius) {
  auto m = gt(load("  - {type: floor, min: [-2, -6], max: [8, 6]}\n"));
  ASSERT_EQ(ds::relabelGroundTruth(ds::GroundTruthConfig(), Eigen::Vector2d(1, 0), 4.0, &m), "");
  EXPECT_EQ(at(m, 4.9, 0), SafetyLabel::kLevel);
  EXPECT_EQ(at(m, 5.2, 0), SafetyLabel::kUnexamined);  // beyond R_max (000 Alg. 1 step 3)
  EXPECT_EQ(at(m, 1, 4.5), SafetyLabel::kUnexamined);
}

TEST(GroundTruth, BadInputIsReportedNotCrashed) {
  ds::GroundTruthMap m;
  // Start on an obstacle.
  auto sf = load(
      "  - {type: floor, min: [-2, -2], max: [4, 2]}\n"
      "  - {type: box, base: [0, 0, 0], size: [0.5, 0.5, 0.5]}\n");
  EXPECT_NE(ds::computeGroundTruth(sf.scene, ds::GroundTruthConfig(), Eigen::Vector2d(0, 0), &m),
            "");
  EXPECT_TRUE(m.labels.empty());
  // Start off the ground, NaN start, no ground at all, invalid config.
  EXPECT_NE(ds::computeGroundTruth(sf.scene, ds::GroundTruthConfig(), Eigen::Vector2d(9, 9), &m),
            "");
  EXPECT_NE(ds::computeGroundTruth(sf.scene, ds::GroundTruthConfig(),
                                   Eigen::Vector2d(std::nan(""), 0), &m),
            "");
  ds::Scene empty;
  EXPECT_NE(ds::computeGroundTruth(empty, ds::GroundTruthConfig(), Eigen::Vector2d(0, 0), &m), "");
  ds::GroundTruthConfig bad;
  bad.robot_height = -1.0;
  EXPECT_NE(ds::computeGroundTruth(sf.scene, bad, Eigen::Vector2d(1, 1), &m).find("robot_height"),
            std::string::npos);
  ds::GroundTruthMap blank;
  EXPECT_NE(ds::relabelGroundTruth(ds::GroundTruthConfig(), Eigen::Vector2d(0, 0), 0.0, &blank),
            "");
  EXPECT_NE(ds::writeGroundTruthFiles("/nonexistent_dir_xyz", sf.scene, ds::GroundTruthConfig(),
                                      blank, {}, {}),
            "");
}

TEST(GroundTruth, WritesMapServerFiles) {
  const auto sf = load(kCurb);
  const auto m = gt(sf);
  const std::string dir = tempDir();
  ASSERT_FALSE(dir.empty());
  ASSERT_EQ(ds::writeGroundTruthFiles(dir, sf.scene, ds::GroundTruthConfig(), m,
                                      ds::groundTruthPlanes(sf.scene, m),
                                      ds::groundTruthObstacles(sf.scene)),
            "");
  const std::string pgm = slurp(dir + "/gt_labels.pgm");
  std::ostringstream header;
  header << "P5\n" << m.width << " " << m.height << "\n255\n";
  ASSERT_EQ(pgm.size(), header.str().size() + static_cast<std::size_t>(m.width) * m.height);
  EXPECT_EQ(pgm.substr(0, header.str().size()), header.str());
  // Top-left pixel is the cell (min_u, max_v); the robot's cell holds Level's raw value.
  const std::size_t body = header.str().size();
  const int r = m.height - 1 - (0 - m.min_v), c = 0 - m.min_u;
  EXPECT_EQ(static_cast<int>(static_cast<unsigned char>(pgm[body + r * m.width + c])),
            static_cast<int>(SafetyLabel::kLevel));
  const std::string grey = slurp(dir + "/gt_map.pgm");
  EXPECT_EQ(static_cast<unsigned char>(grey[body + r * m.width + c]), 254);
  const std::string yaml = slurp(dir + "/gt_map.yaml");
  EXPECT_NE(yaml.find("image: gt_map.pgm"), std::string::npos);
  EXPECT_NE(yaml.find("resolution: 0.1"), std::string::npos);
  EXPECT_NE(yaml.find("mode: trinary"), std::string::npos);
  EXPECT_NE(slurp(dir + "/gt_planes.yaml").find("name: \"lower\""), std::string::npos);
  EXPECT_NE(slurp(dir + "/gt_obstacles.yaml").find("obstacles:"), std::string::npos);
  for (const char* f : {"gt_map.pgm", "gt_map.yaml", "gt_labels.pgm", "gt_drop_off.pgm",
                        "gt_planes.yaml", "gt_obstacles.yaml"})
    std::remove((dir + "/" + f).c_str());
  rmdir(dir.c_str());
}

TEST(SceneLoader, ReportsErrorsWithoutCrashing) {
  ds::SceneFile sf;
  EXPECT_NE(ds::loadSceneFromString("", "", &sf), "");
  EXPECT_NE(ds::loadSceneFromString("name: [unclosed", "", &sf), "");
  EXPECT_NE(ds::loadSceneFromString("name: x\n", "", &sf).find("primitives"), std::string::npos);
  EXPECT_NE(
      ds::loadSceneFromString("primitives:\n  - {type: spaceship}\n", "", &sf).find("spaceship"),
      std::string::npos);
  EXPECT_NE(ds::loadSceneFromString("primitives:\n  - {type: floor, min: [0, 0], max: [1, 1], "
                                    "colour: 3}\n",
                                    "", &sf)
                .find("colour"),
            std::string::npos);  // a typo'd / unknown key
  EXPECT_NE(
      ds::loadSceneFromString("primitives:\n  - {type: ramp, from: [0, 0], to: [0, 0]}\n", "", &sf),
      "");
  EXPECT_NE(ds::loadSceneFromString(
                "primitives:\n  - {type: box, center: [0, 0, x], size: [1, 1, 1]}\n", "", &sf)
                .find("center"),
            std::string::npos);
  EXPECT_NE(ds::loadSceneFromString("primitives:\n  - {type: floor, min: [0, 0], max: [1, 1], "
                                    "material: nosuch}\n",
                                    "", &sf)
                .find("nosuch"),
            std::string::npos);
  EXPECT_NE(ds::loadSceneFromString("camera: {width: -1}\nprimitives: []\n", "", &sf).find("width"),
            std::string::npos);
  EXPECT_NE(ds::loadSceneFromFile("/nonexistent/scene.yaml", "", &sf), "");
  EXPECT_NE(ds::loadSceneFromString("primitives: []\n", "nosuchvariant", &sf), "");
}

TEST(SceneLoader, MaterialsTrajectoryVariantsAndRepeat) {
  const std::string yaml =
      "name: demo\nlook: outdoor\nseed: 7\n"
      "camera: {hfov_deg: 55, pitch_deg: 25}\n"
      "materials:\n  grey: {texture: tiles, scale: 0.4, contrast: 0.2, colour: [128, 128, 128]}\n"
      "primitives:\n"
      "  - {type: floor, name: f, min: [-1, -1], max: [9, 1], z: 0.2, material: grey}\n"
      "  - {type: board, name: b, base: [5, 0, 0.2], size: [0.02, 1, 1], "
      "material: {texture: plain, colour: 0.9}, repeat: {count: 3, offset: [1, 0, 0]}}\n"
      "trajectory:\n  rate_hz: 10\n  start: [0, 0, 0]\n"
      "  steps:\n    - {pause: 1}\n    - {go: [2, 0], speed: 0.5}\n"
      "variants:\n  near: {trajectory: {start: [3, 0, 0]}}\n  far: {}\n";
  ds::SceneFile sf;
  ASSERT_EQ(ds::loadSceneFromString(yaml, "", &sf), "");
  EXPECT_EQ(sf.scene.name, "demo");
  EXPECT_TRUE(sf.scene.outdoor);
  EXPECT_EQ(sf.seed, 7u);
  EXPECT_DOUBLE_EQ(sf.camera.hfov_deg, 55.0);
  EXPECT_DOUBLE_EQ(sf.camera.pitch_deg, 25.0);
  EXPECT_NEAR(sf.trajectory.base_z, 0.2, 1e-12);  // the floor under the start
  ASSERT_EQ(sf.scene.primitives.size(), 4u);      // floor + 3 boards
  EXPECT_NEAR(sf.scene.primitives[3].obb.center.x(), 7.0, 1e-12);
  EXPECT_FALSE(sf.scene.primitives[1].ground);
  EXPECT_TRUE(sf.scene.primitives[0].ground);
  const ds::Material& grey = sf.scene.materials[sf.scene.primitives[0].material];
  EXPECT_EQ(grey.texture, ds::TextureKind::kTiles);
  EXPECT_NEAR(grey.colour.x(), 128.0 / 255.0, 1e-6);
  EXPECT_EQ(sf.trajectory.steps.size(), 2u);
  ASSERT_EQ(sf.variants.size(), 2u);
  EXPECT_EQ(sf.variants[0], "near");
  ASSERT_EQ(ds::loadSceneFromString(yaml, "near", &sf), "");
  EXPECT_EQ(sf.scene.name, "demo_near");
  EXPECT_DOUBLE_EQ(sf.trajectory.start_x, 3.0);
  EXPECT_EQ(sf.trajectory.steps.size(), 2u);  // untouched keys survive the merge
}

// The repository's benchmark scenes (scenes/*.yaml): they load, their robot starts on drivable
// ground and stays on safe ground, and the five dataset scenes mirror 000 Sec. VII-A
// (350-500 frames, 10-20 % stationary).
TEST(BenchmarkScenes, LoadAndHaveSaneGroundTruth) {
  // SSM_SOURCE_DIR (CMakeLists.txt) is the repository; __FILE__ is not reliable: ccache's
  // CCACHE_BASEDIR (scripts/lib/common.sh) makes it relative to the build folder.
#ifdef SSM_SOURCE_DIR
  const std::string root = SSM_SOURCE_DIR;
#else
  const std::string root = ".";
#endif
  const std::string dir = root + "/scenes";
  DIR* d = opendir(dir.c_str());
  ASSERT_NE(d, nullptr) << dir;
  std::vector<std::string> files;
  while (dirent* e = readdir(d)) {
    const std::string n = e->d_name;
    if (n.size() > 5 && n.substr(n.size() - 5) == ".yaml") files.push_back(n);
  }
  closedir(d);
  int datasets = 0;
  for (const std::string& f : files) {
    ds::SceneFile probe;
    ASSERT_EQ(ds::loadSceneFromFile(dir + "/" + f, "", &probe), "") << f;
    std::vector<std::string> variants = probe.variants;
    if (variants.empty()) variants.push_back("");
    for (const std::string& v : variants) {
      ds::SceneFile sf;
      ASSERT_EQ(ds::loadSceneFromFile(dir + "/" + f, v, &sf), "") << f << " " << v;
      ds::GroundTruthMap m;
      ASSERT_EQ(
          ds::computeGroundTruth(sf.scene, ds::GroundTruthConfig(),
                                 Eigen::Vector2d(sf.trajectory.start_x, sf.trajectory.start_y), &m),
          "")
          << f << " " << v;
      const auto poses = ds::sampleTrajectory(sf.trajectory);
      ASSERT_FALSE(poses.empty()) << f;
      int stationary = 0;
      for (const auto& p : poses) {
        EXPECT_TRUE(stereo_safety_map::isSafe(m.labelAtPoint(p.x, p.y)))
            << f << " " << v << ": robot leaves safe ground at t=" << p.t;
        stationary += p.stationary ? 1 : 0;
      }
      if (f.rfind("dataset", 0) == 0) {
        ++datasets;
        EXPECT_GE(poses.size(), 350u) << f;
        EXPECT_LE(poses.size(), 500u) << f;
        const double frac = double(stationary) / poses.size();
        EXPECT_GE(frac, 0.10) << f;
        EXPECT_LE(frac, 0.20) << f;
      }
    }
  }
  EXPECT_EQ(datasets, 5);
}
