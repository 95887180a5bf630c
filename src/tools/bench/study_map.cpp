// bench_pipeline's studies 1 and 1b: the whole pipeline per frame and the mapper on a dense map,
// each with the map stages of 000 called one by one and our plane fit against PCL's.
#include "bench.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <memory>

namespace bench {

namespace {

// On `mapper`'s current grid: the map stages of SafetyMapper::computeSafetyMap() called one by
// one, with thread CPU time and allocations per stage; the state of the map; then the largest
// segment's plane by our least squares (000 Sec. V-B) and by pcl::SACSegmentation (plane,
// RANSAC, 0.02 m) on the very same points.
void studyMap(const ssm::SafetyMapper& mapper, const Eigen::Vector3f& base, int reps, Registry& reg,
              MapStudy* st) {
  const ssm::SafetyMapperConfig& mc = mapper.config();
  if (!st->height_map) {
    st->height_map = std::make_unique<ssm::HeightMap>(mc.height_map);
    st->segmentation = std::make_unique<ssm::GroundSegmentation>(mc.segmentation);
    st->fitter = std::make_unique<ssm::PlaneFitter>(mc.plane_fit);
    st->labelling = std::make_unique<ssm::SafetyLabelling>(mc.labelling);
  }
  const ssm::VoxelGrid& grid = mapper.grid();
  const double l = grid.config().voxel_size;
  const std::string group = "map stages called directly (" + st->what + ")";
  const std::string id = "map" + st->suffix + ".";
  const Sample hm = measure([&] { st->height_map->build(grid, base.z()); });
  const Sample sg = measure(
      [&] { st->segmentation->segment(*st->height_map, grid.indexOf(base), l, &st->segs); });
  const Sample pf = measure([&] { st->fitter->fitAll(grid, st->segs, &st->planes); });
  const Sample lb =
      measure([&] { st->labelling->label(*st->height_map, st->segs, st->planes, l, &st->map); });
  Sample sum;
  for (const Sample* x : {&sg, &pf, &lb}) {
    sum.wall += x->wall;
    sum.cpu += x->cpu;
    sum.news += x->news;
    sum.mallocs += x->mallocs;
  }
  reg.get(id + "height_map", group, "HeightMap::build", "ours").add(hm);
  reg.get(id + "segmentation", group, "GroundSegmentation::segment (Alg. 1)", "ours").add(sg);
  reg.get(id + "plane_fit", group, "PlaneFitter::fitAll (every segment)", "ours").add(pf);
  reg.get(id + "labelling", group, "SafetyLabelling::label (Alg. 2)", "ours").add(lb);
  reg.get(id + "seg_fit_label", group, "segmentation + plane fit + labelling", "ours").add(sum);
  const ssm::GroundSegments& segs = st->segs;
  st->segments.push_back(segs.numSegments());
  int with_height = 0;
  for (std::int32_t w : st->height_map->data())
    with_height += w != ssm::HeightMap::kNoHeight;
  st->columns.push_back(with_height);
  st->seed.push_back(segs.seed_cell >= 0 ? 1.0 : 0.0);

  int best = -1;
  for (int i = 0; i < segs.numSegments(); ++i) {
    if (best < 0 || segs.segmentSize(i) > segs.segmentSize(best)) best = i;
  }
  if (best < 0) return;
  std::vector<Eigen::Vector3d> points;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  const int w = segs.segment_height[best];
  for (const int* c = segs.cellsBegin(best); c != segs.cellsEnd(best); ++c) {
    for (const ssm::VoxelPoint& p :
         grid.points(ssm::VoxelIndex{segs.cellU(*c), segs.cellV(*c), w})) {
      points.push_back(p.position.cast<double>());
      cloud->push_back(pcl::PointXYZ(p.position.x(), p.position.y(), p.position.z()));
    }
  }
  if (points.size() < 3) return;
  const ssm::PlaneFitConfig& cfg = mc.plane_fit;
  const ssm::PlaneFitter& fitter = *st->fitter;
  pcl::SACSegmentation<pcl::PointXYZ> sac;
  sac.setOptimizeCoefficients(true);
  sac.setModelType(pcl::SACMODEL_PLANE);
  sac.setMethodType(pcl::SAC_RANSAC);
  sac.setDistanceThreshold(0.02);
  sac.setInputCloud(cloud);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coeffs;
  const std::string fgroup = "plane fit, largest segment (" + st->what + ")";
  Series& a = reg.get("planefit" + st->suffix + ".ours_segment", fgroup,
                      "PlaneFitter::fitSegment (gathers the voxel point lists)", "ours");
  Series& b = reg.get("planefit" + st->suffix + ".ours_points", fgroup,
                      "fitPlane() on the gathered points (least squares, 000 V-B)", "ours");
  Series& c = reg.get("planefit" + st->suffix + ".pcl_sac", fgroup,
                      "pcl::SACSegmentation plane, RANSAC, 0.02 m, same points", "peer");
  ssm::GroundPlane ours, ours_pts;
  for (int rep = 0; rep < reps; ++rep) {
    a.add(measure([&] { ours = fitter.fitSegment(grid, segs, best); }));
    b.add(measure([&] { ours_pts = ssm::fitPlane(points, cfg); }));
    c.add(measure([&] { sac.segment(inliers, coeffs); }));
  }
  st->fit_points.push_back(static_cast<double>(points.size()));
  if (coeffs.values.size() == 4 && ours.valid) {
    const Eigen::Vector3d n(coeffs.values[0], coeffs.values[1], coeffs.values[2]);
    st->fit_angle.push_back(angleDeg(n, ours.normal));
    st->inlier_fraction.push_back(static_cast<double>(inliers.indices.size()) /
                                  static_cast<double>(points.size()));
  }
}

// Stage list of StageTimings / StereoFrameTimings, in pipeline order.
const char* const kStageKeys[] = {"disparity",  "reproject",     "integrate",
                                  "height_map", "segmentation",  "plane_fit",
                                  "labelling",  "seg_fit_label", "total"};

}  // namespace

void studyPipeline(Bench* b) {
  const Options& opt = b->opt;
  auto& frames = b->frames;
  auto& measured = b->measured;
  auto& cam = b->cam;
  auto& pcfg = b->pcfg;
  auto& reg = b->reg;
  auto& extra = b->extra;
  auto& problems = b->problems;
  auto& points_of = b->points_of;
  auto& disparity_of = b->disparity_of;
  auto& not_integrated = b->not_integrated;
  auto& pipeline_map = b->pipeline_map;
  // ---- 1. the whole pipeline per frame (StereoFrameProcessor: BM + filters, default mapper) ---
  points_of.assign(frames.size(), {});
  disparity_of.assign(measured.size(), cv::Mat());
  {
    progress("whole pipeline: %d warm-up + %d measured frames", opt.warmup, opt.frames);
    ssm::StereoFrameProcessor proc(pcfg);
    Series& s_total = reg.get("pipeline.frame", "whole pipeline per frame",
                              "whole frame: stereo pair -> safety map (BM + filters)", "ours");
    const char* stage_labels[] = {"disparity + filters (BM)",
                                  "reprojection",
                                  "voxel grid update (recenter + integrate)",
                                  "height map",
                                  "segmentation (Alg. 1)",
                                  "plane fit (all segments)",
                                  "labelling (Alg. 2)",
                                  "segmentation + plane fit + labelling",
                                  "total (StereoFrameTimings)"};
    for (int k = 0; k < 9; ++k) {
      reg.get(std::string("pipeline.") + kStageKeys[k], "whole pipeline per frame", stage_labels[k],
              "ours", "wall time from the core's StereoFrameTimings");
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const Frame& f = frames[k];
      ssm::StereoFrameResult res;
      std::string err;
      bool ok = false;
      const Sample s = measure([&] {
        ok = proc.processImages(f.left, f.right, cam, f.T_fixed_left, f.base, f.stamp, &res, &err);
      });
      points_of[k] = proc.points();
      if (!ok) {
        ++not_integrated;
        progress("frame %zu not integrated: %s", f.index, err.c_str());
        continue;
      }
      if (static_cast<int>(k) < opt.warmup) continue;
      const std::size_t m = k - static_cast<std::size_t>(opt.warmup);
      disparity_of[m] = proc.disparity().clone();
      s_total.add(s);
      const ssm::StereoFrameTimings& t = res.timings;
      const ssm::StageTimings& st = t.mapper;
      const double values[9] = {
          t.disparity_ms,     t.reproject_ms,
          st.integrate_ms,    st.height_map_ms,
          st.segmentation_ms, st.plane_fit_ms,
          st.labelling_ms,    st.segmentation_ms + st.plane_fit_ms + st.labelling_ms,
          t.total_ms};
      for (int i = 0; i < 9; ++i)
        reg.get(std::string("pipeline.") + kStageKeys[i], "", "", "").addWall(values[i]);
      extra["points_sum"] += static_cast<double>(res.points);
      extra["points_frames"] += 1.0;
      studyMap(proc.mapper(), f.base, 3 * opt.passes, reg, &pipeline_map);
    }
  }
  if (extra["points_frames"] > 0.0) {
    extra["points_per_frame_mean"] = extra["points_sum"] / extra["points_frames"];
  } else {
    problems.push_back("no measured frame was integrated by the pipeline");
  }
}

void studyDenseMap(Bench* b) {
  const Options& opt = b->opt;
  auto& frames = b->frames;
  auto& cam = b->cam;
  auto& pcfg = b->pcfg;
  auto& reg = b->reg;
  auto& comparisons = b->comparisons;
  auto& extra = b->extra;
  auto& dense_points_of = b->dense_points_of;
  auto& pipeline_map = b->pipeline_map;
  auto& dense_map = b->dense_map;
  // ---- 1b. a dense map: the same frames through OpenCV SGBM without any filter --------------
  // On this poorly textured dataset BM + filters keeps ~5 % of the pixels, too few for the map
  // to grow ground segments within a benchmark's frames, so the map stages would be timed on a
  // nearly empty map. The dense points (~70 % of the pixels) fill it: an upper bound for the
  // segmentation, plane fit and labelling, and for the voxel update (section 4).
  dense_points_of.assign(frames.size(), {});
  {
    progress("dense map (SGBM points): %zu frames", frames.size());
    ssm::DisparityPipelineConfig dense_cfg = pcfg.disparity;
    dense_cfg.matcher = ssm::StereoMatcherType::kSemiGlobal;
    dense_cfg.enable_uniqueness = false;
    const cv::Ptr<cv::StereoMatcher> matcher = ssm::DisparityPipeline::matcherFor(dense_cfg);
    cv::Mat raw16, disparity;
    for (std::size_t k = 0; k < frames.size(); ++k) {
      matcher->compute(frames[k].left, frames[k].right, raw16);
      raw16.convertTo(disparity, CV_32F, 1.0 / cv::StereoMatcher::DISP_SCALE);
      ssm::reprojectDisparity(disparity, cam, pcfg.mapper.grid.min_range,
                              pcfg.mapper.grid.max_range, 1, &dense_points_of[k]);
    }
    // --quick has too few frames for any voxel to reach occ_t = 100 (ten hits, 000 Sec. IV):
    // there the dense map uses the package's single-frame configuration (occ_t = incr_H) so that
    // the segment and plane-fit code still runs.
    const ssm::SafetyMapperConfig mcfg =
        opt.quick ? ssm::singleFrameMapperConfig(pcfg.mapper, 2.0) : pcfg.mapper;
    ssm::SafetyMapper mapper(mcfg);
    const std::string group = "mapper on the dense map (SGBM points, no filter)";
    const char* labels[] = {"voxel grid update (recenter + integrate)",
                            "height map",
                            "segmentation (Alg. 1)",
                            "plane fit (all segments)",
                            "labelling (Alg. 2)",
                            "segmentation + plane fit + labelling",
                            "integrateFrame total"};
    const char* keys[] = {"integrate", "height_map",    "segmentation", "plane_fit",
                          "labelling", "seg_fit_label", "total"};
    Series& s_frame = reg.get("mapper_dense.frame", group,
                              "SafetyMapper::integrateFrame (thread CPU, allocations)", "ours");
    for (int i = 0; i < 7; ++i) {
      reg.get(std::string("mapper_dense.") + keys[i], group, labels[i], "ours",
              "wall time from the core's StageTimings");
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const Frame& f = frames[k];
      ssm::FrameResult r;
      bool ok = false;
      const Sample s = measure(
          [&] { ok = mapper.integrateFrame(dense_points_of[k], f.T_fixed_left, f.base, &r); });
      if (static_cast<int>(k) < opt.warmup || !ok) continue;
      s_frame.add(s);
      const ssm::StageTimings& t = r.timings;
      const double values[7] = {
          t.integrate_ms, t.height_map_ms, t.segmentation_ms,
          t.plane_fit_ms, t.labelling_ms,  t.segmentation_ms + t.plane_fit_ms + t.labelling_ms,
          t.total_ms};
      for (int i = 0; i < 7; ++i)
        reg.get(std::string("mapper_dense.") + keys[i], "", "", "").addWall(values[i]);
      studyMap(mapper, f.base, 3 * opt.passes, reg, &dense_map);
    }
    extra["dense_quick_single_frame_config"] = opt.quick ? 1.0 : 0.0;
  }
  for (MapStudy* st : {&pipeline_map, &dense_map}) {
    comparisons.push_back({"planefit" + st->suffix + ".ours_segment",
                           "planefit" + st->suffix + ".pcl_sac",
                           "plane fit of the largest segment (" + st->what + ")"});
    comparisons.push_back({"planefit" + st->suffix + ".ours_points",
                           "planefit" + st->suffix + ".pcl_sac",
                           "same, points already gathered (" + st->what + ")"});
  }
}

}  // namespace bench
