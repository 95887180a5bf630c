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

TEST(EvaluatorEndToEnd, SmallRenderedDatasetHasLowErrorRates) {
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

  StereoCameraModel camera;
  camera.fx = camera.fy = head.fx();
  camera.cx = camera.cx_right = head.cx();
  camera.cy = head.cy();
  camera.baseline = head.baseline;
  camera.width = head.width;
  camera.height = head.height;

  StereoFrameProcessorConfig config;
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
  cv::Mat left, right;
  for (std::size_t k = 0; k < xs.size(); ++k) {
    const Eigen::Isometry3d T_base = ds::basePose(xs[k], 0.0, 0.0, 0.0);
    renderer.render(T_base * T_base_optical, k, &left, &right);
    StereoFrameResult result;
    std::string error;
    const bool ok =
        processor.processImages(left, right, camera, (T_base * T_base_optical).cast<float>(),
                                Eigen::Vector3f(xs[k], 0.0f, 0.0f), &result, &error);
    if (!ok) {
      ASSERT_EQ(result.mapper.status, FrameStatus::kStationary) << error;
      ++stationary;
      continue;  // 000 Sec. VII-A: stationary frames are not evaluated
    }
    ++integrated;
    EXPECT_GT(result.points, 1000u);
    const SafetyMap& map = processor.mapper().safetyMap();
    ConfusionCounts frame;
    ASSERT_EQ(countConfusion(map, gt, &frame), "");
    sum += frame;
    if (map.robot_segment >= 0) seeded += frame;
    for (const SegmentInfo& s : map.segments) {
      if (!isSafe(s.label) || !s.plane.valid) continue;
      const PlaneAccuracy a = comparePlane(s.plane, s.cells, map, refs);
      if (!a.matched) continue;
      angles.push_back(a.angle_deg);
      distances.push_back(a.mean_distance);
    }
  }
  EXPECT_EQ(stationary, 2);
  EXPECT_EQ(integrated, 40);
  EXPECT_EQ(sum.maps, 40u);

  const ErrorRates rates = errorRates(sum);
  const ErrorRates seeded_rates = errorRates(seeded);
  const SafeClassScores scores = safeClassScores(seeded);
  const MeanStd angle = meanStd(angles), distance = meanStd(distances);
  std::printf(
      "e2e: TP %llu FP %llu FN %llu TN %llu; FN %.2f %% FP %.2f %% (%llu maps with the "
      "robot's segment: FN %.2f %% FP %.2f %%; P %.3f R %.3f F1 %.3f); planes %d: %.2f +- "
      "%.2f deg, %.2f +- %.2f cm\n",
      static_cast<unsigned long long>(sum.tp), static_cast<unsigned long long>(sum.fp),
      static_cast<unsigned long long>(sum.fn), static_cast<unsigned long long>(sum.tn),
      100 * rates.fn, 100 * rates.fp, static_cast<unsigned long long>(seeded.maps),
      100 * seeded_rates.fn, 100 * seeded_rates.fp, scores.precision, scores.recall, scores.f1,
      angle.n, angle.mean, angle.stddev, 100 * distance.mean, 100 * distance.stddev);

  // Enough of both classes compared for the rates to mean something.
  EXPECT_GT(sum.unsafeCells(), 40u * 50u);
  EXPECT_GT(sum.safeCells(), 40u * 300u);
  EXPECT_GE(seeded.maps, 20u);
  EXPECT_LT(rates.fn, 0.02);
  EXPECT_LT(rates.fp, 0.35);  // the first frames, before the seed, are all Non-ground
  EXPECT_LT(seeded_rates.fn, 0.02);
  EXPECT_LT(seeded_rates.fp, 0.05);
  EXPECT_GT(scores.f1, 0.95);
  ASSERT_GT(angle.n, 0);
  EXPECT_LT(angle.mean, 1.0);
  EXPECT_LT(distance.mean, 0.025);
}

}  // namespace
}  // namespace stereo_safety_map
