// The evaluation chain end to end on a small rendered dataset: a floor with a box on it and a
// 0.3 m drop-off, seen by the synthetic stereo head (dataset/renderer.h) while the robot drives
// towards them, processed frame by frame by StereoFrameProcessor (the code the evaluator tool and
// the nodelets run) and compared with the analytic ground truth (dataset/ground_truth.h) by the
// metrics of 000 Sec. VII-A / VII-C. The rates are bounded from above (the pipeline works) and the
// counts from below (the comparison really happened); a map that gets the classes wrong fails.
#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

namespace ds = dataset;

ds::Primitive solid(ds::Primitive p, int material, bool ground, const std::string& name) {
  p.material = material;
  p.ground = ground;
  p.name = name;
  p.group = name;
  p.type = ground ? "floor" : "box";
  return p;
}

ds::Material noise(double scale, double contrast, float grey, std::uint32_t seed) {
  ds::Material m;
  m.texture = ds::TextureKind::kNoise;
  m.scale = scale;
  m.contrast = contrast;
  m.colour = Eigen::Vector3f(grey, grey, grey);
  m.seed = seed;
  return m;
}

// Upper floor (top z = 0) for x < 4.5, lower floor 0.3 m down beyond it, a 0.6 x 0.6 x 0.8 m box
// on the upper floor to the robot's left.
ds::Scene smallScene() {
  ds::Scene s;
  s.name = "e2e";
  const int floor = s.addMaterial("floor", noise(0.15, 0.7, 0.55f, 1));
  const int low = s.addMaterial("low", noise(0.15, 0.7, 0.35f, 2));
  const int box = s.addMaterial("box", noise(0.1, 0.8, 0.7f, 3));
  s.add(solid(ds::makeBox({0.75, 0.0, -0.5}, {7.5, 8.0, 1.0}), floor, true, "upper_floor"));
  s.add(solid(ds::makeBox({7.5, 0.0, -0.8}, {6.0, 8.0, 1.0}), low, true, "lower_floor"));
  s.add(solid(ds::makeBox({3.0, 1.0, 0.4}, {0.6, 0.6, 0.8}), box, false, "box"));
  return s;
}

LabelGrid toLabelGrid(const ds::GroundTruthMap& gt) {
  LabelGrid g;
  g.min_u = gt.min_u;
  g.min_v = gt.min_v;
  g.width = gt.width;
  g.height = gt.height;
  g.resolution = gt.resolution;
  g.labels = gt.labels;
  return g;
}

std::vector<ReferencePlane> toReferencePlanes(const std::vector<ds::GroundTruthPlane>& planes) {
  std::vector<ReferencePlane> out;
  for (const auto& p : planes) {
    ReferencePlane r;
    r.name = p.name;
    r.a = p.a;
    r.b = p.b;
    r.c = p.c;
    for (const auto& q : p.polygon)
      r.footprint.emplace_back(q.x(), q.y());
    out.push_back(r);
  }
  return out;
}

struct E2EResult {
  ConfusionCounts sum, seeded;
  // False positives (maps with the robot's segment) with no ground-truth Non-ground cell within
  // one cell: the ones not at a face or an edge.
  std::uint64_t seeded_fp_away = 0;
  int integrated = 0, stationary = 0;
  MeanStd angle, distance;
};

// Runs the small scene through StereoFrameProcessor with `config` and compares every map with
// the ground truth.
void runEndToEnd(const StereoFrameProcessorConfig& config, E2EResult* out) {
  const ds::Scene scene = smallScene();
  ASSERT_EQ(scene.validate(), "");
  ds::StereoHeadConfig head;
  head = head.scaledTo(320, 240);
  head.threads = 1;
  ds::StereoRenderer renderer(scene, head, 7);

  ds::GroundTruthConfig gtc;
  ds::GroundTruthMap gt_map;
  ASSERT_EQ(ds::computeGroundTruth(scene, gtc, Eigen::Vector2d(0.0, 0.0), &gt_map), "");
  const LabelGrid gt = toLabelGrid(gt_map);
  const std::vector<ReferencePlane> refs = toReferencePlanes(ds::groundTruthPlanes(scene, gt_map));
  ASSERT_GE(refs.size(), 2u);

  const StereoCameraModel camera = ds::stereoCameraModel(head);

  StereoFrameProcessor processor(config);
  const Eigen::Isometry3d T_base_optical = head.baseToLeftOptical();

  // 40 poses 5 cm apart along +x, the 10th repeated twice (stationary frames, 000 Sec. IV).
  std::vector<double> xs;
  for (int i = 0; i < 40; ++i) {
    xs.push_back(0.05 * i);
    if (i == 10) xs.insert(xs.end(), 2, 0.05 * i);
  }

  // All maps (000 Sec. VII-A) and, separately, the maps in which the robot's segment was found:
  // until the camera has seen the ground within the segmentation's seed radius of the robot, Alg. 1
  // has no segment to grow and every column with a height is labelled Non-ground.
  ConfusionCounts sum, seeded;
  int integrated = 0, stationary = 0;
  std::vector<double> angles, distances;
  std::vector<CellOutcome> outcomes;
  cv::Mat left, right;
  for (std::size_t k = 0; k < xs.size(); ++k) {
    const Eigen::Isometry3d T_base = ds::basePose(xs[k], 0.0, 0.0, 0.0);
    renderer.render(T_base * T_base_optical, k, &left, &right);
    StereoFrameResult result;
    std::string error;
    const bool ok =
        processor.processImages(left, right, camera, (T_base * T_base_optical).cast<float>(),
                                Eigen::Vector3f(xs[k], 0.0f, 0.0f), 0.1 * k, &result, &error);
    if (!ok) {
      ASSERT_EQ(result.mapper.status, FrameStatus::kStationary) << error;
      ++stationary;
      continue;  // 000 Sec. VII-A: stationary frames are not evaluated
    }
    ++integrated;
    EXPECT_GT(result.points, 1000u);
    const SafetyMap& map = processor.mapper().safetyMap();
    ConfusionCounts frame;
    ASSERT_EQ(countConfusion(map, gt, &frame, &outcomes), "");
    sum += frame;
    if (map.robot_segment >= 0) {
      seeded += frame;
      for (int c = 0; c < static_cast<int>(outcomes.size()); ++c) {
        if (outcomes[c] != CellOutcome::kFalsePositive) continue;
        const int u = map.min_u + c % map.width, v = map.min_v + c / map.width;
        bool near = false;
        for (int dv = -1; dv <= 1 && !near; ++dv)
          for (int du = -1; du <= 1 && !near; ++du)
            near = gt.at(u + du, v + dv) == SafetyLabel::kNonGround;
        if (!near) ++out->seeded_fp_away;
      }
    }
    for (const SegmentInfo& s : map.segments) {
      if (!isSafe(s.label) || !s.plane.valid) continue;
      const PlaneAccuracy a = comparePlane(s.plane, s.cells, map, refs);
      if (!a.matched) continue;
      angles.push_back(a.angle_deg);
      distances.push_back(a.mean_distance);
    }
  }
  out->sum = sum;
  out->seeded = seeded;
  out->integrated = integrated;
  out->stationary = stationary;
  out->angle = meanStd(angles);
  out->distance = meanStd(distances);
}

void print(const char* label, const E2EResult& r) {
  const ErrorRates rates = errorRates(r.sum), seeded = errorRates(r.seeded);
  const SafeClassScores scores = safeClassScores(r.seeded);
  std::printf(
      "e2e %s: TP %llu FP %llu FN %llu TN %llu; FN %.2f %% FP %.2f %% (%llu maps with the "
      "robot's segment: FN %.2f %% FP %.2f %%; P %.3f R %.3f F1 %.3f); planes %d: %.2f +- "
      "%.2f deg, %.2f +- %.2f cm; FP away from faces and edges %llu\n",
      label, static_cast<unsigned long long>(r.sum.tp), static_cast<unsigned long long>(r.sum.fp),
      static_cast<unsigned long long>(r.sum.fn), static_cast<unsigned long long>(r.sum.tn),
      100 * rates.fn, 100 * rates.fp, static_cast<unsigned long long>(r.seeded.maps),
      100 * seeded.fn, 100 * seeded.fp, scores.precision, scores.recall, scores.f1, r.angle.n,
      r.angle.mean, r.angle.stddev, 100 * r.distance.mean, 100 * r.distance.stddev,
      static_cast<unsigned long long>(r.seeded_fp_away));
}

void expectComparedAndAccurate(const E2EResult& r) {
  EXPECT_EQ(r.stationary, 2);
  EXPECT_EQ(r.integrated, 40);
  EXPECT_EQ(r.sum.maps, 40u);
  // Enough of both classes compared for the rates to mean something.
  EXPECT_GT(r.sum.unsafeCells(), 40u * 50u);
  EXPECT_GT(r.sum.safeCells(), 40u * 300u);
  EXPECT_GE(r.seeded.maps, 20u);
  EXPECT_LT(errorRates(r.sum).fp, 0.35);  // the first frames, before the seed, are all Non-ground
  EXPECT_GT(safeClassScores(r.seeded).f1, 0.95);
  ASSERT_GT(r.angle.n, 0);
  EXPECT_LT(r.angle.mean, 1.0);
  EXPECT_LT(r.distance.mean, 0.025);
}

// Without the obstacle face margin the cell-exact rates of 000 Sec. VII-A (no tolerance at the
// labels' boundaries) are bounded; the margin's ring of Non-ground cells at the box's faces is
// measured by the test after this one.
TEST(EvaluatorEndToEnd, SmallRenderedDatasetHasLowErrorRates) {
  StereoFrameProcessorConfig config;
  config.mapper.labelling.obstacle_face_margin = false;
  E2EResult r;
  runEndToEnd(config, &r);
  print("defaults without the face margin", r);
  expectComparedAndAccurate(r);
  EXPECT_LT(errorRates(r.sum).fn, 0.005);
  EXPECT_LT(errorRates(r.seeded).fn, 0.005);
  EXPECT_LT(errorRates(r.seeded).fp, 0.08);
}

// The obstacle face margin (SafetyLabellingConfig::obstacle_face_margin, on by default) makes the
// floor's cells at the box's faces Non-ground: false positives within one cell of the box or the
// drop, not away from them; misses do not grow.
TEST(EvaluatorEndToEnd, ObstacleFaceMarginAddsNonGroundOnlyAtFaces) {
  StereoFrameProcessorConfig without;
  without.mapper.labelling.obstacle_face_margin = false;
  StereoFrameProcessorConfig with;
  ASSERT_TRUE(with.mapper.labelling.obstacle_face_margin);
  E2EResult a, b;
  runEndToEnd(without, &a);
  runEndToEnd(with, &b);
  print("defaults", b);
  expectComparedAndAccurate(b);
  EXPECT_LE(b.sum.fn, a.sum.fn);
  EXPECT_GT(b.seeded.fp, a.seeded.fp);  // the ring is there
  // What the margin adds lies at the faces: at most a third of it away from them (measured: 293
  // cells added, 66 of them away; with obstacle_face_min_rise at h_T, 774 and 547: the ring
  // then also grows around stereo's 5-10 cm bumps on the floor).
  EXPECT_LE(b.seeded_fp_away, a.seeded_fp_away + (b.seeded.fp - a.seeded.fp) / 3);
  EXPECT_LT(errorRates(b.seeded).fp, 0.15);
}

// obstacle_face_reach (default 3 cm, growing with 2 stereo range errors) asks the face column's
// points through the mapper's grid: the margin it makes is part of the full ring's
// (obstacle_face_reach >= l_v), and misses do not grow on this scene (measured: the same maps;
// the box is seen from 1.5-4 m, where 2 range errors exceed the cell). A reach of 0 without the
// range term rings (almost) nothing: the mapper hands the labelling its grid.
TEST(EvaluatorEndToEnd, ObstacleFaceReachKeepsThePartOfTheRingAFaceReaches) {
  StereoFrameProcessorConfig full;
  full.mapper.labelling.obstacle_face_reach = 1.0;
  StereoFrameProcessorConfig reach;
  ASSERT_LT(reach.mapper.labelling.obstacle_face_reach, 0.1);
  ASSERT_GT(reach.mapper.labelling.obstacle_face_reach_sigmas, 0.0);
  E2EResult a, b;
  runEndToEnd(full, &a);
  runEndToEnd(reach, &b);
  print("face margin, every face column", a);
  print("face margin, reach (defaults)", b);
  expectComparedAndAccurate(b);
  EXPECT_LE(b.seeded.fp, a.seeded.fp);
  EXPECT_LE(b.sum.fn, a.sum.fn);
  StereoFrameProcessorConfig none;
  none.mapper.labelling.obstacle_face_reach = 0.0;
  none.mapper.labelling.obstacle_face_reach_sigmas = 0.0;
  E2EResult c;
  runEndToEnd(none, &c);
  print("face margin, reach 0", c);
  EXPECT_LT(c.seeded.fp, a.seeded.fp);
}

// The drop-off margin (SafetyLabellingConfig::drop_off_margin) trades false positives along the
// drop's upper edge for the false negatives of the safe side bleeding over it.
TEST(EvaluatorEndToEnd, DropOffMarginTradesFalsePositivesForFalseNegatives) {
  StereoFrameProcessorConfig with;
  with.mapper.labelling.obstacle_face_margin = false;  // the drop-off margin alone
  StereoFrameProcessorConfig without = with;
  without.mapper.labelling.drop_off_margin = false;
  E2EResult a, b;
  runEndToEnd(without, &a);
  runEndToEnd(with, &b);
  print("without margin", a);
  expectComparedAndAccurate(a);
  EXPECT_LT(errorRates(a.sum).fn, 0.02);
  EXPECT_LT(errorRates(a.seeded).fp, 0.05);
  EXPECT_GT(a.sum.fn, 0u);  // the bleeding the margin is for happens here
  EXPECT_LT(b.sum.fn, a.sum.fn);
  EXPECT_GT(b.sum.fp, a.sum.fp);
}

}  // namespace
}  // namespace stereo_safety_map
