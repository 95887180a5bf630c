// StereoFrameProcessor: one stereo frame through disparity, reprojection and the mapper, the code
// shared by the offline evaluator and the nodelets. Worlds: a rendered floor with a box (known
// geometry) and synthetic disparity images of a level floor.
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

namespace stereo_safety_map {
namespace {

namespace ds = dataset;
constexpr double kNoStamp = StereoFrameProcessor::kNoStamp;

ds::StereoHeadConfig smallHead() {
  ds::StereoHeadConfig h;
  h = h.scaledTo(320, 240);
  h.threads = 1;
  return h;
}

StereoCameraModel cameraOf(const ds::StereoHeadConfig& h) {
  return ds::stereoCameraModel(h);
}

ds::Scene floorWithBox() {
  ds::Scene s;
  ds::Material m;
  m.texture = ds::TextureKind::kNoise;
  m.scale = 0.15;
  m.contrast = 0.7;
  const int mat = s.addMaterial("m", m);
  ds::Primitive floor = ds::makeBox({3.0, 0.0, -0.5}, {12.0, 10.0, 1.0});
  floor.material = mat;
  floor.ground = true;
  floor.name = "floor";
  s.add(floor);
  ds::Primitive box = ds::makeBox({3.0, 0.0, 0.4}, {0.6, 0.6, 0.8});
  box.material = mat;
  box.name = "box";
  s.add(box);
  return s;
}

// Disparity of the level floor z = 0 seen by `head` from its mount on a base at the origin.
cv::Mat floorDisparity(const ds::StereoHeadConfig& head) {
  const Eigen::Isometry3d T = head.baseToLeftOptical();  // base = world
  const StereoCameraModel cam = cameraOf(head);
  cv::Mat d(head.height, head.width, CV_32FC1, cv::Scalar(0.0f));
  for (int y = 0; y < head.height; ++y) {
    for (int x = 0; x < head.width; ++x) {
      const Eigen::Vector3d ray_c((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0);
      const Eigen::Vector3d ray_w = T.linear() * ray_c;
      if (ray_w.z() >= -1e-6) continue;
      const double s = -T.translation().z() / ray_w.z();  // depth Z along the optical axis
      if (s > 7.0) continue;
      d.at<float>(y, x) = static_cast<float>(cam.disparityFromDepth(s));
    }
  }
  return d;
}

TEST(StereoFrameProcessorConfig, ValidateNamesTheParameter) {
  EXPECT_EQ(StereoFrameProcessorConfig().validate(), "");
  StereoFrameProcessorConfig c;
  c.disparity_step = 17;
  EXPECT_NE(c.validate().find("disparity_step"), std::string::npos);
  c = StereoFrameProcessorConfig();
  c.mapper.grid.voxel_size = -1.0;
  EXPECT_NE(c.validate().find("mapper."), std::string::npos);
  c = StereoFrameProcessorConfig();
  c.disparity.num_disparities = 15;
  EXPECT_NE(c.validate().find("disparity."), std::string::npos);
  EXPECT_THROW(StereoFrameProcessor{c}, std::invalid_argument);
}

TEST(SingleFrameMapperConfig, OneHitNoDecrementsWideSeed) {
  const SafetyMapperConfig base;
  const SafetyMapperConfig c = singleFrameMapperConfig(base, 3.0);
  EXPECT_EQ(c.grid.occ_threshold, base.grid.incr_high);
  EXPECT_EQ(c.grid.decr, 0);
  EXPECT_DOUBLE_EQ(c.segmentation.seed_radius, 3.0);
  EXPECT_FALSE(c.skip_stationary_frames);
  EXPECT_EQ(c.validate(), "");
  // Everything else keeps the paper's values.
  EXPECT_EQ(c.grid.incr_high, base.grid.incr_high);
  EXPECT_DOUBLE_EQ(c.labelling.max_slope_deg, base.labelling.max_slope_deg);
  EXPECT_DOUBLE_EQ(c.segmentation.planning_radius, base.segmentation.planning_radius);
}

// A map from few frames of the level floor (R_max 3 m); stationary frames skipped or not, without
// the warm-up: 000 Sec. IV (the warm-up: test_safety_mapper). With the obstacle cue taking one
// point per cell for 1 s.
StereoFrameProcessorConfig floorConfig(bool skip_stationary) {
  StereoFrameProcessorConfig c;
  c.mapper = singleFrameMapperConfig(c.mapper, 3.0);
  c.mapper.skip_stationary_frames = skip_stationary;
  c.mapper.stationary_warmup_frames = 0;
  c.cue.lifetime = 1.0;
  c.cue.min_points_per_cell = 1;
  return c;
}

TEST(StereoFrameProcessor, DisparityOfALevelFloorGivesALevelMapAndSkipsStationaryFrames) {
  const ds::StereoHeadConfig head = smallHead();
  const cv::Mat disparity = floorDisparity(head);
  const StereoFrameProcessorConfig c = floorConfig(true);
  StereoFrameProcessor p(c);
  const Eigen::Isometry3f T = head.baseToLeftOptical().cast<float>();
  StereoFrameResult r;
  std::string err;
  ASSERT_TRUE(
      p.processDisparity(disparity, cameraOf(head), T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err))
      << err;
  EXPECT_EQ(r.mapper.status, FrameStatus::kIntegrated);
  EXPECT_GT(r.points, 10000u);
  EXPECT_EQ(r.points, p.points().size());
  EXPECT_TRUE(p.disparity().empty());
  const SafetyMap& map = p.mapper().safetyMap();
  ASSERT_GE(map.robot_segment, 0);
  const SegmentInfo& s = map.segments[map.robot_segment];
  EXPECT_EQ(s.label, SafetyLabel::kLevel);
  ASSERT_TRUE(s.plane.valid);
  EXPECT_NEAR(s.plane.c, 0.0, 0.02);
  EXPECT_LT(s.plane.slope_deg, 0.5);

  // The same pose again: stationary, refused, map kept.
  const std::size_t cells = s.cells.size();
  EXPECT_FALSE(p.processDisparity(disparity, cameraOf(head), T, Eigen::Vector3f::Zero(), kNoStamp,
                                  &r, &err));
  EXPECT_EQ(r.mapper.status, FrameStatus::kStationary);
  EXPECT_NE(err.find("stationary"), std::string::npos);
  EXPECT_EQ(p.mapper().safetyMap().segments[map.robot_segment].cells.size(), cells);

  p.reset();
  EXPECT_EQ(p.mapper().framesIntegrated(), 0u);
}

// Row gap fill (disparity_gap_fill.h): a floor seen only on its joints (every 24th column, 3 px
// wide, as a tiled floor without texture gives a block matcher) leaves most of the map Unknown;
// with the fill on the floor between the joints is found, on the map's copy only.
TEST(StereoFrameProcessor, RowGapFillFindsTheFloorBetweenItsJoints) {
  const ds::StereoHeadConfig head = smallHead();
  cv::Mat joints = floorDisparity(head);
  for (int x = 0; x < joints.cols; ++x)
    if (x % 24 >= 3) joints.col(x).setTo(cv::Scalar(0.0f));
  const cv::Mat input = joints.clone();
  auto levelCells = [](const SafetyMap& m) {
    int n = 0;
    for (int v = m.min_v; v < m.min_v + m.height; ++v)
      for (int u = m.min_u; u < m.min_u + m.width; ++u)
        n += m.labelAt(u, v) == SafetyLabel::kLevel;
    return n;
  };
  const Eigen::Isometry3f T = head.baseToLeftOptical().cast<float>();
  StereoFrameProcessorConfig c;
  c.mapper = singleFrameMapperConfig(c.mapper, 3.0);
  StereoFrameProcessor off(c);
  c.row_gap_fill.enabled = true;
  StereoFrameProcessor on(c);
  StereoFrameResult r_off, r_on;
  std::string err;
  ASSERT_TRUE(off.processDisparity(joints, cameraOf(head), T, Eigen::Vector3f::Zero(), kNoStamp,
                                   &r_off, &err))
      << err;
  ASSERT_TRUE(on.processDisparity(joints, cameraOf(head), T, Eigen::Vector3f::Zero(), kNoStamp,
                                  &r_on, &err))
      << err;
  EXPECT_EQ(r_off.gap_filled, 0);
  EXPECT_GT(r_on.gap_filled, 0);
  EXPECT_GT(r_on.points, 3 * r_off.points);
  EXPECT_EQ(cv::countNonZero(joints != input), 0);  // the caller's disparity is not touched
  EXPECT_GT(levelCells(on.mapper().safetyMap()), levelCells(off.mapper().safetyMap()) * 3 / 2);
}

// 001 Sec. 4.2 in front of the grid: a blob of mismatched pixels that appears in one place for
// one frame only (a ghost 0.7 m in front of the camera, where the floor is 2 m and more away)
// reaches the mapper without the landmark filter and never with it; the floor does.
TEST(StereoFrameProcessor, LandmarkFilterKeepsOneFrameGhostsFromTheGrid) {
  const ds::StereoHeadConfig head = smallHead();
  const cv::Mat floor = floorDisparity(head);
  const StereoCameraModel cam = cameraOf(head);
  const float ghost_d = static_cast<float>(cam.disparityFromDepth(0.7));
  for (bool filter : {false, true}) {
    StereoFrameProcessorConfig c;
    c.mapper = singleFrameMapperConfig(c.mapper, 3.0);  // a map from few frames
    c.landmark_filter.enabled = filter;
    StereoFrameProcessor p(c);
    std::size_t ghosts_to_grid = 0, floor_to_grid = 0;
    for (int k = 0; k < 10; ++k) {
      cv::Mat d = floor.clone();
      const int x0 = 20 + (k * 97) % (head.width - 60), y0 = 120 + (k * 37) % 80;
      d(cv::Rect(x0, y0, 16, 16)).setTo(ghost_d);
      // The robot drives 5 cm a frame: every frame is integrated.
      Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
      base.translation().x() = 0.05 * k;
      const Eigen::Isometry3f T = (base * head.baseToLeftOptical()).cast<float>();
      StereoFrameResult r;
      std::string err;
      const bool ok = p.processDisparity(d, cam, T, base.translation().cast<float>(),
                                         1000.0 + 0.1 * k, &r, &err);
      EXPECT_EQ(r.landmark_filter_ran, filter);
      if (filter && k < c.landmark_filter.filter.min_matches) {
        // No landmark is permanent yet: nothing reaches the grid.
        EXPECT_FALSE(ok);
        EXPECT_EQ(r.mapper.status, FrameStatus::kEmptyInput);
        EXPECT_EQ(r.points, 0u);
        continue;
      }
      ASSERT_TRUE(ok) << "frame " << k << ": " << err;
      EXPECT_EQ(r.points, p.points().size());
      EXPECT_LE(r.points, r.points_reprojected);
      for (const Eigen::Vector3f& q : p.points()) {
        if (q.z() < 1.0f) {
          ++ghosts_to_grid;
        } else {
          ++floor_to_grid;
        }
      }
    }
    if (filter) {
      EXPECT_EQ(ghosts_to_grid, 0u);
      EXPECT_GT(p.landmarkFilter().stats().permanent, 100u);
    } else {
      EXPECT_EQ(ghosts_to_grid, 10u * 16u * 16u);
    }
    EXPECT_GT(floor_to_grid, 10000u);
    const SafetyMap& map = p.mapper().safetyMap();
    ASSERT_GE(map.robot_segment, 0);
    EXPECT_EQ(map.segments[map.robot_segment].label, SafetyLabel::kLevel);
  }
}

TEST(StereoFrameProcessor, LandmarkFilterSkipsStationaryFramesAndNeedsAStamp) {
  const ds::StereoHeadConfig head = smallHead();
  const cv::Mat floor = floorDisparity(head);
  StereoFrameProcessorConfig c;
  c.landmark_filter.enabled = true;
  StereoFrameProcessor p(c);
  const Eigen::Isometry3f T = head.baseToLeftOptical().cast<float>();
  StereoFrameResult r;
  std::string err;
  EXPECT_FALSE(p.processDisparity(floor, cameraOf(head), T, Eigen::Vector3f::Zero(), kNoStamp, &r,
                                  &err));  // no stamp
  EXPECT_NE(err.find("stamp"), std::string::npos) << err;
  // Standing still before the first map: only the first frame reaches the filter, the others
  // are stationary (they would confirm each other's points).
  for (int k = 0; k < 4; ++k) {
    p.processDisparity(floor, cameraOf(head), T, Eigen::Vector3f::Zero(), -1.0 + 0.1 * k, &r, &err);
    EXPECT_EQ(r.landmark_filter_ran, k == 0) << k;
    if (k > 0) {
      EXPECT_EQ(r.mapper.status, FrameStatus::kStationary);
    }
  }
  EXPECT_EQ(p.landmarkFilter().stats().permanent, 0u);
  EXPECT_EQ(p.mapper().framesIntegrated(), 0u);
  p.reset();
  for (int k = 0; k < 4; ++k) {
    Eigen::Isometry3f moved = T;
    moved.translation().x() += 0.05f * k;
    p.processDisparity(floor, cameraOf(head), moved, Eigen::Vector3f(0.05f * k, 0.f, 0.f), 0.1 * k,
                       &r, &err);
  }
  ASSERT_EQ(r.mapper.status, FrameStatus::kIntegrated) << err;
  const std::size_t permanent = p.landmarkFilter().stats().permanent;
  // The camera stops: the filter does not see the frame (a stationary camera would confirm its
  // own mismatches), the mapper skips it.
  Eigen::Isometry3f still = T;
  still.translation().x() += 0.15f;
  EXPECT_FALSE(p.processDisparity(floor, cameraOf(head), still, Eigen::Vector3f(0.15f, 0.f, 0.f),
                                  0.5, &r, &err));
  EXPECT_EQ(r.mapper.status, FrameStatus::kStationary);
  EXPECT_FALSE(r.landmark_filter_ran);
  EXPECT_EQ(p.landmarkFilter().stats().permanent, permanent);
  p.reset();
  std::vector<Eigen::Vector3f> cloud;
  p.landmarkFilter().permanentLandmarks(&cloud);
  EXPECT_TRUE(cloud.empty());
}

TEST(StereoFrameProcessor, ImagesAndTheirDisparityGiveTheSameMap) {
  // The evaluator runs the images; the nodelet gets a disparity image. Same disparity, same map.
  const ds::StereoHeadConfig head = smallHead();
  ds::StereoRenderer renderer(floorWithBox(), head, 3);
  StereoFrameProcessorConfig c;
  StereoFrameProcessor from_images(c), from_disparity(c);
  const StereoCameraModel cam = cameraOf(head);
  cv::Mat left, right;
  for (int k = 0; k < 12; ++k) {
    const Eigen::Isometry3d T_base = ds::basePose(0.05 * k, 0.0, 0.0, 0.0);
    const Eigen::Isometry3f T = (T_base * head.baseToLeftOptical()).cast<float>();
    const Eigen::Vector3f robot(0.05f * k, 0.0f, 0.0f);
    renderer.render(T_base * head.baseToLeftOptical(), k, &left, &right);
    StereoFrameResult ri, rd;
    std::string err;
    ASSERT_TRUE(from_images.processImages(left, right, cam, T, robot, 0.1 * k, &ri, &err)) << err;
    ASSERT_TRUE(from_disparity.processDisparity(
        from_images.disparity(), from_images.disparityCamera(), T, robot, 0.1 * k, &rd, &err))
        << err;
    EXPECT_EQ(ri.points, rd.points);
    EXPECT_GT(ri.disparity.valid, 0);
    EXPECT_GT(ri.timings.disparity_ms, 0.0);
    EXPECT_GE(ri.timings.total_ms, ri.timings.disparity_ms);
  }
  EXPECT_EQ(from_images.mapper().safetyMap().labels, from_disparity.mapper().safetyMap().labels);
  // The box 3 m ahead is an obstacle in the map.
  const SafetyMap& map = from_images.mapper().safetyMap();
  int non_ground_near_box = 0;
  for (int v = -3; v <= 3; ++v)
    for (int u = 27; u <= 33; ++u)
      non_ground_near_box += map.inside(u, v) && map.labelAt(u, v) == SafetyLabel::kNonGround;
  EXPECT_GT(non_ground_near_box, 5);
}

TEST(StereoFrameProcessor, PointsAndDisparityGoThroughTheSameMapper) {
  // The cloud input (processPoints) and the disparity input give the same map from the same
  // points: one frame path whatever the sensor.
  const ds::StereoHeadConfig head = smallHead();
  const cv::Mat disparity = floorDisparity(head);
  const StereoCameraModel cam = cameraOf(head);
  StereoFrameProcessor from_disparity, from_points;
  std::string err;
  for (int k = 0; k < 12; ++k) {
    const Eigen::Isometry3d T_base = ds::basePose(0.05 * k, 0.0, 0.0, 0.0);
    const Eigen::Isometry3f T = (T_base * head.baseToLeftOptical()).cast<float>();
    const Eigen::Vector3f robot(0.05f * k, 0.0f, 0.0f);
    StereoFrameResult rd, rp;
    ASSERT_TRUE(from_disparity.processDisparity(disparity, cam, T, robot, 0.1 * k, &rd, &err))
        << err;
    const std::vector<Eigen::Vector3f> points = from_disparity.points();
    ASSERT_TRUE(from_points.processPoints(points, T, robot, 0.1 * k, &rp, &err)) << err;
    EXPECT_EQ(rp.points, rd.points);
    EXPECT_FALSE(rp.landmark_filter_ran);
  }
  EXPECT_EQ(from_points.mapper().safetyMap().labels, from_disparity.mapper().safetyMap().labels);
  EXPECT_GT(from_points.mapper().safetyMap().labels.size(), 0u);
}

TEST(StereoFrameProcessor, StampsAgeTheMap) {
  // The stamp reaches the mapper: a map not re-observed for max_cell_age falls back to Unknown
  // (the nodelet's behaviour, now the offline evaluators' too).
  const ds::StereoHeadConfig head = smallHead();
  const cv::Mat disparity = floorDisparity(head);
  const StereoCameraModel cam = cameraOf(head);
  StereoFrameProcessorConfig c;
  c.mapper = singleFrameMapperConfig(c.mapper, 3.0);
  c.mapper.max_cell_age = 1.0;
  StereoFrameProcessor p(c);
  const Eigen::Isometry3f T = head.baseToLeftOptical().cast<float>();
  StereoFrameResult r;
  std::string err;
  ASSERT_TRUE(p.processDisparity(disparity, cam, T, Eigen::Vector3f::Zero(), 10.0, &r, &err))
      << err;
  EXPECT_EQ(p.mapper().cellsAged(), 0u);
  EXPECT_DOUBLE_EQ(p.mapper().latestTime(), 10.0);
  // 2 s later without a frame: every safe cell is older than max_cell_age.
  const std::size_t safe = std::count_if(p.mapper().safetyMap().labels.begin(),
                                         p.mapper().safetyMap().labels.end(), isSafe);
  ASSERT_GT(safe, 100u);
  EXPECT_EQ(p.mapper().ageSafetyMap(12.0), safe);
  // Without a stamp the frame is not aged.
  StereoFrameProcessor q(c);
  ASSERT_TRUE(q.processDisparity(disparity, cam, T, Eigen::Vector3f::Zero(),
                                 StereoFrameProcessor::kNoStamp, &r, &err));
  EXPECT_TRUE(std::isnan(q.mapper().latestTime()));
}

TEST(StereoFrameProcessor, ObstacleCueIsAnOptionalStageThatOnlyAddsNonGround) {
  const ds::StereoHeadConfig head = smallHead();
  const cv::Mat disparity = floorDisparity(head);
  const StereoCameraModel cam = cameraOf(head);
  StereoFrameProcessorConfig c = floorConfig(false);
  EXPECT_TRUE(c.obstacle_cue) << "on by default (README, \"Obstacle cue\")";
  c.obstacle_cue = false;
  StereoFrameProcessor off(c);
  EXPECT_FALSE(off.addObstacleCue(1.0, {Eigen::Vector3f(2.0f, 0.0f, 0.3f)}));
  c.obstacle_cue = true;
  StereoFrameProcessor on(c);
  EXPECT_FALSE(on.addObstacleCue(StereoFrameProcessor::kNoStamp, {}));
  // A cue on floor cells 2 m ahead: Non-ground in the next map, the rest untouched.
  const std::vector<Eigen::Vector3f> cue = {Eigen::Vector3f(2.0f, 0.0f, 0.3f),
                                            Eigen::Vector3f(2.0f, 0.1f, 0.3f)};
  EXPECT_TRUE(on.addObstacleCue(10.0, cue));
  EXPECT_EQ(on.cueCount(), 1);
  const Eigen::Isometry3f T = head.baseToLeftOptical().cast<float>();
  StereoFrameResult r_off, r_on;
  std::string err;
  ASSERT_TRUE(off.processDisparity(disparity, cam, T, Eigen::Vector3f::Zero(), 10.2, &r_off, &err));
  ASSERT_TRUE(on.processDisparity(disparity, cam, T, Eigen::Vector3f::Zero(), 10.2, &r_on, &err));
  EXPECT_FALSE(r_off.cue_applied);
  ASSERT_TRUE(r_on.cue_applied);
  EXPECT_EQ(r_on.cue.cells_marked, 2u);
  const SafetyMap& plain = off.mapper().safetyMap();
  const SafetyMap& fused = on.mapper().safetyMap();
  ASSERT_EQ(plain.labels.size(), fused.labels.size());
  ASSERT_EQ(on.cueMarked().size(), fused.labels.size());
  ASSERT_EQ(plain.labelAt(20, 0), SafetyLabel::kLevel);
  EXPECT_EQ(fused.labelAt(20, 0), SafetyLabel::kNonGround);
  EXPECT_EQ(fused.labelAt(20, 1), SafetyLabel::kNonGround);
  int changed = 0;
  for (std::size_t k = 0; k < plain.labels.size(); ++k) {
    if (plain.labels[k] == fused.labels[k]) continue;
    ++changed;
    EXPECT_EQ(fused.labels[k], SafetyLabel::kNonGround);
    EXPECT_EQ(on.cueMarked()[k], 1);
  }
  EXPECT_EQ(changed, 2);
  // recompute() (a stage reconfigured) applies the live cue again.
  on.recompute(Eigen::Vector3f::Zero(), 10.3);
  EXPECT_EQ(on.mapper().safetyMap().labelAt(20, 0), SafetyLabel::kNonGround);
  // Past its lifetime the cue is gone: the map is 000's again.
  ASSERT_TRUE(on.processDisparity(disparity, cam, T, Eigen::Vector3f::Zero(), 11.5, &r_on, &err));
  ASSERT_TRUE(off.processDisparity(disparity, cam, T, Eigen::Vector3f::Zero(), 11.5, &r_off, &err));
  EXPECT_EQ(on.mapper().safetyMap().labels, off.mapper().safetyMap().labels);
  EXPECT_EQ(on.cueCount(), 0);
  // reset() forgets the cues.
  EXPECT_TRUE(on.addObstacleCue(12.0, cue));
  on.reset();
  EXPECT_EQ(on.cueCount(), 0);
}

// A chair at rest (000 Sec. IV skips its frames): an obstacle that 003's detector reports now
// still reaches the map (the nodelet republishes it at every stationary frame), and leaves it
// once its cue has expired, while the grid stays untouched.
TEST(StereoFrameProcessor, CuesReachTheMapWhileTheChairStandsStill) {
  const ds::StereoHeadConfig head = smallHead();
  const cv::Mat disparity = floorDisparity(head);
  const StereoCameraModel cam = cameraOf(head);
  StereoFrameProcessor p(floorConfig(true));
  const Eigen::Isometry3f T = head.baseToLeftOptical().cast<float>();
  const Eigen::Vector3f base = Eigen::Vector3f::Zero();
  StereoFrameResult r;
  std::string err;
  ASSERT_TRUE(p.processDisparity(disparity, cam, T, base, 10.0, &r, &err)) << err;
  const std::vector<SafetyLabel> before = p.mapper().safetyMap().labels;
  ASSERT_EQ(p.mapper().safetyMap().labelAt(20, 0), SafetyLabel::kLevel);
  // At rest, no cue: the frame is skipped and nothing is recomputed.
  EXPECT_FALSE(p.processDisparity(disparity, cam, T, base, 10.1, &r, &err));
  EXPECT_EQ(r.mapper.status, FrameStatus::kStationary);
  EXPECT_FALSE(r.map_refreshed);
  // Someone steps in front of the chair: the detector's cue arrives; the next stationary frame
  // marks it, the grid still holds one frame.
  ASSERT_TRUE(p.addObstacleCue(10.15, {Eigen::Vector3f(2.0f, 0.0f, 0.3f)}));
  EXPECT_FALSE(p.processDisparity(disparity, cam, T, base, 10.2, &r, &err));
  EXPECT_EQ(r.mapper.status, FrameStatus::kStationary);
  EXPECT_TRUE(r.map_refreshed);
  ASSERT_TRUE(r.cue_applied);
  EXPECT_EQ(r.cue.cells_marked, 1u);
  EXPECT_EQ(p.mapper().framesIntegrated(), 1u);
  const SafetyMap& at_rest = p.mapper().safetyMap();
  EXPECT_EQ(at_rest.labelAt(20, 0), SafetyLabel::kNonGround);
  int changed = 0;
  for (std::size_t k = 0; k < before.size() && k < at_rest.labels.size(); ++k)
    changed += before[k] != at_rest.labels[k] ? 1 : 0;
  EXPECT_EQ(changed, 1);
  // The cue expires (lifetime 1 s) while the chair still stands: the mark leaves the map.
  EXPECT_FALSE(p.processDisparity(disparity, cam, T, base, 11.5, &r, &err));
  EXPECT_TRUE(r.map_refreshed);
  EXPECT_EQ(p.cueCount(), 0);
  EXPECT_EQ(p.mapper().safetyMap().labels, before);
  // Nothing live and nothing marked: the next stationary frame recomputes nothing.
  EXPECT_FALSE(p.processDisparity(disparity, cam, T, base, 11.6, &r, &err));
  EXPECT_FALSE(r.map_refreshed);
}

TEST(StereoFrameProcessor, CoarseReadingsBuildOccupancyAndCarveOnlyWhenAllowed) {
  // A camera 1 m above the base looking along +x: full-resolution readings of a surface 2 m
  // ahead in columns [100, 140), coarse-fill readings 4 m ahead in the columns just beside it
  // ([140, 150)), whose rays graze the near surface's voxels. With coarse_free_space (the first
  // rule) those rays carve them; without it the near surface's log-odds are those of a frame
  // without the coarse readings, and the coarse readings still occupy their own voxels.
  const ds::StereoHeadConfig head = smallHead();
  const StereoCameraModel cam = cameraOf(head);
  cv::Mat fine(cam.height, cam.width, CV_32FC1, cv::Scalar(0.0f));
  cv::Mat coarse = fine.clone();
  fine(cv::Rect(100, 100, 40, 40)).setTo(static_cast<float>(cam.disparityFromDepth(2.0)));
  coarse(cv::Rect(140, 100, 10, 40)).setTo(static_cast<float>(cam.disparityFromDepth(4.0)));
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  Eigen::Matrix3f optical_to_body;
  optical_to_body << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T.linear() = optical_to_body;
  T.translation() = Eigen::Vector3f(0.0f, 0.0f, 1.0f);
  auto run = [&](bool free_space, bool with_coarse) {
    StereoFrameProcessorConfig c;
    c.mapper.skip_stationary_frames = false;
    c.obstacle_cue = false;
    c.coarse_free_space = free_space;
    auto p = std::make_unique<StereoFrameProcessor>(c);
    for (int k = 0; k < 12; ++k) {
      StereoFrameResult r;
      std::string err;
      EXPECT_TRUE(p->processDisparity(fine, cam, T, Eigen::Vector3f::Zero(), 0.1 * k, &r, &err,
                                      with_coarse ? coarse : cv::Mat()))
          << err;
    }
    return p;
  };
  const auto none = run(true, false), carving = run(true, true), evidence = run(false, true);
  // The near surface's voxels: x = 2 m, the columns of the strip's right edge (y < 0 in the
  // body frame is the image's right), over its rows.
  const VoxelGrid& g_none = none->mapper().grid();
  const VoxelGridConfig& gc = g_none.config();
  long sum_none = 0, sum_carving = 0, sum_evidence = 0;
  for (int u = 19; u <= 21; ++u) {
    for (int v = -20; v <= 20; ++v) {
      for (int w = 0; w <= 20; ++w) {
        const VoxelIndex i{u, v, w};
        sum_none += std::max(0, g_none.logOdds(i));
        sum_carving += std::max(0, carving->mapper().grid().logOdds(i));
        sum_evidence += std::max(0, evidence->mapper().grid().logOdds(i));
      }
    }
  }
  ASSERT_GT(sum_none, 0);
  EXPECT_EQ(sum_evidence, sum_none);
  EXPECT_LT(sum_carving, sum_none);
  // The coarse readings 4 m ahead occupy their voxels either way.
  int occupied_carving = 0, occupied_evidence = 0;
  for (int v = -20; v <= 20; ++v) {
    for (int w = 0; w <= 20; ++w) {
      for (int u = 39; u <= 41; ++u) {
        occupied_carving += carving->mapper().grid().isOccupied(VoxelIndex{u, v, w});
        occupied_evidence += evidence->mapper().grid().isOccupied(VoxelIndex{u, v, w});
      }
    }
  }
  EXPECT_GT(occupied_evidence, 0);
  EXPECT_EQ(occupied_evidence, occupied_carving);
  (void)gc;
  // A coarse image of the wrong size is refused.
  StereoFrameProcessor p;
  std::string err;
  EXPECT_FALSE(p.processDisparity(fine, cam, T, Eigen::Vector3f::Zero(), 0.0, nullptr, &err,
                                  cv::Mat(3, 3, CV_32FC1, cv::Scalar(1.0f))));
  EXPECT_NE(err.find("coarse"), std::string::npos) << err;
}

TEST(StereoFrameProcessor, TheCoarseFillsReadingsComeOnTheirOwn) {
  // processImages with the coarse fill and coarse_free_space off: disparity() holds the
  // full-resolution readings alone, coarseDisparity() the filled ones; together they are the
  // pipeline's output. With coarse_free_space on (default) disparity() is that merged output,
  // the disparity nodelet's message, and coarseDisparity() is empty.
  ds::Scene scene = floorWithBox();
  scene.materials[0].contrast = 0.05;  // a pale floor: the fine level keeps little of it
  const ds::StereoHeadConfig head = smallHead();
  ds::StereoRenderer renderer(scene, head, 3);
  cv::Mat left, right;
  const Eigen::Isometry3d T = head.baseToLeftOptical();
  ASSERT_TRUE(renderer.render(T, 0, &left, &right, nullptr, nullptr));
  StereoFrameProcessorConfig c;
  c.disparity.coarse_fill_levels = 1;
  c.coarse_free_space = true;
  StereoFrameProcessor merged_path(c);
  c.coarse_free_space = false;
  StereoFrameProcessor p(c);
  StereoFrameResult r;
  std::string err;
  p.processImages(left, right, cameraOf(head), T.cast<float>(), Eigen::Vector3f::Zero(), 0.0, &r,
                  &err);
  merged_path.processImages(left, right, cameraOf(head), T.cast<float>(), Eigen::Vector3f::Zero(),
                            0.0, &r, &err);
  EXPECT_TRUE(merged_path.coarseDisparity().empty());
  ASSERT_FALSE(p.disparity().empty()) << err;
  ASSERT_FALSE(p.coarseDisparity().empty());
  DisparityPipeline pipeline(c.disparity);
  pipeline.setFocalBaseline(cameraOf(head).fx * cameraOf(head).baseline);
  cv::Mat merged;
  ASSERT_TRUE(pipeline.compute(left, right, &merged, nullptr, &err)) << err;
  int both = 0, coarse = 0, fine = 0, lost = 0, unlike_merged = 0;
  for (int y = 0; y < merged.rows; ++y) {
    for (int x = 0; x < merged.cols; ++x) {
      unlike_merged +=
          (merged.at<float>(y, x) > 0.0f) != (merged_path.disparity().at<float>(y, x) > 0.0f);
      const bool f = p.disparity().at<float>(y, x) > 0.0f;
      const bool k = p.coarseDisparity().at<float>(y, x) > 0.0f;
      both += f && k;
      coarse += k;
      fine += f;
      lost += (merged.at<float>(y, x) > 0.0f) != (f || k);
    }
  }
  EXPECT_EQ(both, 0);
  EXPECT_EQ(lost, 0);
  EXPECT_EQ(unlike_merged, 0);
  EXPECT_GT(coarse, fine);
}

TEST(StereoFrameProcessor, BadInputIsRefusedWithAReason) {
  const ds::StereoHeadConfig head = smallHead();
  StereoFrameProcessor p;
  const StereoCameraModel cam = cameraOf(head);
  const Eigen::Isometry3f T = head.baseToLeftOptical().cast<float>();
  const cv::Mat img(head.height, head.width, CV_8UC1, cv::Scalar(100));
  StereoFrameResult r;
  std::string err;
  StereoCameraModel bad = cam;
  bad.fx = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(p.processImages(img, img, bad, T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  EXPECT_NE(err.find("camera"), std::string::npos);
  const cv::Mat small(10, 10, CV_8UC1, cv::Scalar(1));
  EXPECT_FALSE(p.processImages(small, small, cam, T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  EXPECT_NE(err.find("image"), std::string::npos);
  // The disparity nodelet's input check refuses a missing image and a pair without contrast
  // (a covered or black camera) before matching.
  EXPECT_FALSE(
      p.processImages(img, cv::Mat(), cam, T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  EXPECT_NE(err.find("image"), std::string::npos) << err;
  EXPECT_FALSE(p.processImages(img, img, cam, T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  EXPECT_NE(err.find("contrast"), std::string::npos) << err;
  EXPECT_FALSE(p.processDisparity(cv::Mat(), cam, T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  const cv::Mat wrong_type(head.height, head.width, CV_8UC1, cv::Scalar(5));
  EXPECT_FALSE(
      p.processDisparity(wrong_type, cam, T, Eigen::Vector3f::Zero(), kNoStamp, &r, nullptr));
  // Without the check, the matcher refuses a missing image and a textureless pair gives no
  // points: the mapper refuses the empty frame.
  StereoFrameProcessorConfig unchecked;
  unchecked.check_input = false;
  StereoFrameProcessor q(unchecked);
  EXPECT_FALSE(
      q.processImages(img, cv::Mat(), cam, T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  EXPECT_NE(err.find("disparity"), std::string::npos);
  EXPECT_FALSE(q.processImages(img, img, cam, T, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  EXPECT_EQ(r.mapper.status, FrameStatus::kEmptyInput);
  // Non-finite pose.
  Eigen::Isometry3f nan_pose = T;
  nan_pose.translation().x() = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat disparity = floorDisparity(head);
  EXPECT_FALSE(
      p.processDisparity(disparity, cam, nan_pose, Eigen::Vector3f::Zero(), kNoStamp, &r, &err));
  EXPECT_EQ(r.mapper.status, FrameStatus::kInvalidPose);
  EXPECT_EQ(p.mapper().framesIntegrated(), 0u);
}

}  // namespace
}  // namespace stereo_safety_map
