// evaluate_occupancy_2d: one dataset. Disparity once per stereo pair, the four 2D grid variants
// and the safety map on it, counts within the radius, frame latency, pictures.
#include "evaluate_occupancy_2d.h"

#include "stereo_safety_map/core/disparity_filters.h"
#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/tools/boards.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

namespace evaluate_occupancy_2d {

// ---------------------------------------------------------------------------------------------
// Latency helpers (000 Sec. VII-B, as evaluate_safety_map counts them).

void finishLatency(std::vector<Latency>* v) {
  for (Latency& l : *v) {
    l.frames_to_50 = ssm::framesUntilCoverage(l.coverage, 0.5);
    l.frames_to_90 = ssm::framesUntilCoverage(l.coverage, 0.9);
  }
}

std::string evaluateDataset(const Options& opt, const Setup& setup, const std::string& bag,
                            Kind kind, DatasetResult* res) {
  ssm::Dataset d;
  std::string e = ssm::loadDataset(bag, kind == Kind::kLatency, &d);
  if (!e.empty()) return e;
  res->name = d.name;
  res->kind = kind;
  GtExtras gx;
  const std::vector<ssm::UnsafeCause>& causes = gx.causes;
  if (kind != Kind::kLatency) {
    e = computeCauses(d, opt.scenes, &gx);
    res->causes_ok = e.empty();
    res->gt_cause_cells = gx.cause_cells;
    res->gt_edge_cells = gx.edge_cells;
    if (!e.empty()) {
      res->note = "no causes: " + e;
      std::fprintf(stderr, "warning: %s: %s\n", d.name.c_str(), res->note.c_str());
    }
  }

  // Disparity without spike removal; the filter runs on a copy (it is the pipeline's last step).
  ssm::DisparityPipelineConfig dcfg = setup.core.disparity;
  const ssm::SpikeRemovalConfig spike_cfg = dcfg.spike_removal;
  dcfg.enable_spike_removal = false;
  ssm::DisparityPipeline pipeline(dcfg);
  ssm::DisparityFilterWorkspace spike_ws;

  std::vector<std::unique_ptr<ssm::OccupancyGrid2D>> grids;
  for (const Variant& v : kVariants) {
    ssm::OccupancyGrid2DConfig c = setup.grid;
    c.accuracy_preservation = v.preservation;
    grids.push_back(std::make_unique<ssm::OccupancyGrid2D>(c));
  }
  std::unique_ptr<ssm::StereoFrameProcessor> safety;
  if (opt.safety_map) {
    safety = std::make_unique<ssm::StereoFrameProcessor>(setup.core);
    res->safety_ran = true;
  }
  Latency fresh;
  for (const auto& b : d.boards) {
    fresh.board = b.name;
    for (auto& g : res->grid)
      g.latency.push_back(fresh);
    res->safety.latency.push_back(fresh);
  }

  ssm::StereoBagReaderOptions ro;
  ro.scan_topic.clear();
  ro.max_frames = opt.max_frames;
  ssm::StereoBagReader reader;
  e = reader.open(d.bag, ro);
  if (!e.empty()) return e;
  const int pairs_total = reader.pairCount();
  std::set<int> image_frames;
  for (int k = 1; k <= opt.images && kind != Kind::kLatency; ++k)
    image_frames.insert(k * pairs_total / (opt.images + 1));

  cv::Mat raw, spiked;
  ssm::SafetyMap as_map;
  std::vector<ssm::CellOutcome> outcomes;
  ssm::StereoBagFrame frame;
  int camera_frames = 0;  // frames going by since the first, for the latency
  while (reader.next(&frame)) {
    if (frame.index % opt.every != 0) continue;
    ++res->pairs;
    if (!frame.error.empty()) {
      ++res->rejected;
      ++res->problems[frame.error];
      continue;
    }
    const Eigen::Isometry3f T = frame.T_fixed_sensor.cast<float>();
    const Eigen::Vector3f robot = frame.robot.cast<float>();
    const Eigen::Vector2f robot_xy = robot.head<2>();

    const auto t0 = Clock::now();
    std::string err;
    if (!pipeline.compute(frame.left, frame.right, &raw, nullptr, &err)) {
      ++res->rejected;
      ++res->problems["disparity: " + err];
      continue;
    }
    raw.copyTo(spiked);
    if (setup.core.disparity.enable_spike_removal) {
      ssm::filterSpikes(spike_cfg, &spiked, &spike_ws);  // 002 Sec. 4.2
    }
    const auto t1 = Clock::now();
    res->disparity_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());

    for (int i = 0; i < kNumVariants; ++i) {
      ssm::OccupancyGrid2D& g = *grids[i];
      const auto g0 = Clock::now();
      g.recenter(robot_xy);
      const ssm::Grid2DUpdateStats s =
          g.update(kVariants[i].spikes ? spiked : raw, frame.camera, T, robot.z());
      if (i == 0) {
        res->grid_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - g0).count());
      }
      if (!s.ok()) {
        if (i == 0) ++res->problems[std::string("grid: ") + ssm::toString(s.status)];
        continue;
      }
      MapperResult& m = res->grid[i];
      if (kind != Kind::kLatency) {
        ssm::occupancyGridAsSafetyMap(g, robot_xy, setup.radius, &as_map);
        e = ssm::countConfusion(as_map, d.gt, &m.counts, i == 0 ? &outcomes : nullptr);
        if (!e.empty()) return "confusion: " + e;
        if (res->causes_ok) {
          ssm::countUnsafeCauses(as_map, d.gt, causes, &m.causes);
          ssm::countDropOffEdges(as_map, d.gt, gx.edge, &m.edges);
        }
        ++m.maps;
        if (i == 0 && image_frames.count(frame.index)) {
          const std::string name = d.name + "_frame" + std::to_string(frame.index) + ".png";
          char title[128];
          std::snprintf(title, sizeof(title), "%s frame %d, 2D grid (002)", d.name.c_str(),
                        frame.index);
          cv::imwrite(
              opt.out + "/maps/" + name,
              ssm::mapBesideGroundTruth(as_map, d.gt, outcomes, frame.robot,
                                        ssm::yawOfOpticalAxis(frame.T_fixed_sensor), title));
          res->images.push_back("maps/" + name);
        }
      }
    }

    bool safety_integrated = false;
    if (safety) {
      const auto s0 = Clock::now();
      ssm::StereoFrameResult fr;
      safety_integrated =
          safety->processDisparity(spiked, frame.camera, T, robot, frame.stamp.toSec(), &fr, &err);
      res->safety_ms.push_back(
          std::chrono::duration<double, std::milli>(Clock::now() - s0).count());
      if (safety_integrated && kind != Kind::kLatency) {
        const ssm::SafetyMap& map = safety->mapper().safetyMap();
        e = ssm::countConfusion(map, d.gt, &res->safety.counts);
        if (!e.empty()) return "confusion: " + e;
        if (res->causes_ok) {
          ssm::countUnsafeCauses(map, d.gt, causes, &res->safety.causes);
          ssm::countDropOffEdges(map, d.gt, gx.edge, &res->safety.edges);
        }
        ++res->safety.maps;
      }
    }

    // Latency: camera frames from the board's appearance (first frame with its centre in the
    // left image); a frame the safety map skipped keeps its previous grid.
    for (std::size_t b = 0; b < d.boards.size(); ++b) {
      const ssm::BoardBox& box = d.boards[b].box;
      for (int i = 0; i < kNumVariants; ++i) {
        Latency& l = res->grid[i].latency[b];
        if (l.appear_frame < 0) {
          if (!ssm::boardInView(box, frame.T_fixed_sensor, frame.camera)) continue;
          l.appear_frame = camera_frames;
          l.start_distance = ssm::distanceToBoardFace(box, frame.T_fixed_sensor.translation());
        }
        l.coverage.push_back(ssm::boardWidthCoverage2D(*grids[i], box).fraction());
      }
      if (safety) {
        Latency& l = res->safety.latency[b];
        if (l.appear_frame < 0) {
          if (!ssm::boardInView(box, frame.T_fixed_sensor, frame.camera)) continue;
          l.appear_frame = camera_frames;
          l.start_distance = ssm::distanceToBoardFace(box, frame.T_fixed_sensor.translation());
        }
        l.coverage.push_back(ssm::boardWidthCoverage(safety->mapper().grid(), box).fraction());
      }
    }
    ++camera_frames;
    if (!opt.quiet && frame.index % 100 == 0) {
      const ssm::ConfusionCounts& c = res->grid[0].counts;
      std::fprintf(stderr, "  %s pair %d/%d: 2D grid recall %.3f precision %.3f\n", d.name.c_str(),
                   frame.index, pairs_total, recallOf(c), precisionOf(c));
    }
  }
  for (auto& g : res->grid)
    finishLatency(&g.latency);
  finishLatency(&res->safety.latency);
  return "";
}

}  // namespace evaluate_occupancy_2d
