// bench_pipeline's study 5: scaling with image size (whole pipeline), map size and voxel size
// (the mapper alone on dense points).
#include "bench.h"

#include <algorithm>
#include <exception>

namespace bench {

void studyScaling(Bench* b) {
  const Options& opt = b->opt;
  auto& frames = b->frames;
  auto& sized = b->sized;
  auto& pcfg = b->pcfg;
  auto& problems = b->problems;
  auto& dense_points_of = b->dense_points_of;
  auto& scaling = b->scaling;
  // ---- 5. scaling sweeps ----------------------------------------------------------------------
  if (opt.scaling) {
    progress("scaling: image size");
    for (const SizedFrames& sz : sized) {
      ScalingPoint sp;
      sp.sweep = "image_size";
      sp.x = sz.width;
      sp.label = std::to_string(sz.width) + "x" + std::to_string(sz.height);
      ssm::StereoFrameProcessorConfig c = pcfg;
      // Same depth range at every size: the disparity search grows with the image width.
      c.disparity.num_disparities = std::max(16, 64 * sz.width / 640 / 16 * 16);
      sp.label += ", " + std::to_string(c.disparity.num_disparities) + " disp.";
      try {
        ssm::StereoFrameProcessor proc(c);
        const ssm::StereoCameraModel m = ds::stereoCameraModel(sz.head);
        std::map<std::string, std::vector<double>> w;
        std::vector<double> cpu, pts, mallocs;
        for (std::size_t k = 0; k < sz.frames.size(); ++k) {
          const Frame& f = sz.frames[k];
          ssm::StereoFrameResult res;
          std::string err;
          bool ok = false;
          const Sample s = measure([&] {
            ok =
                proc.processImages(f.left, f.right, m, f.T_fixed_left, f.base, f.stamp, &res, &err);
          });
          if (k == 0 || !ok) continue;  // first frame: warm-up
          const ssm::StageTimings& st = res.timings.mapper;
          w["disparity"].push_back(res.timings.disparity_ms);
          w["reproject"].push_back(res.timings.reproject_ms);
          w["integrate"].push_back(st.integrate_ms);
          w["seg_fit_label"].push_back(st.segmentation_ms + st.plane_fit_ms + st.labelling_ms);
          w["total"].push_back(res.timings.total_ms);
          cpu.push_back(s.cpu);
          pts.push_back(static_cast<double>(res.points));
          mallocs.push_back(s.mallocs);
        }
        for (auto& kv : w)
          sp.wall_median[kv.first] = statsOf(kv.second).median;
        sp.cpu_total_median = statsOf(cpu).median;
        sp.points_median = statsOf(pts).median;
        sp.mallocs_median = statsOf(mallocs).median;
        sp.frames = static_cast<int>(cpu.size());
      } catch (const std::exception& e) {
        sp.error = e.what();
        problems.push_back("image-size sweep " + sp.label + ": " + e.what());
      }
      scaling.push_back(sp);
    }

    // Map and voxel size: the mapper alone on the dense points of every rendered 640x480 frame
    // (the pipeline's sparse points leave the map without segments, see section 1b).
    auto mapperSweep = [&](const std::string& sweep, double x, const std::string& label,
                           const ssm::SafetyMapperConfig& c) {
      ScalingPoint sp;
      sp.sweep = sweep;
      sp.x = x;
      sp.label = label;
      try {
        ssm::SafetyMapper mapper(c);
        std::map<std::string, std::vector<double>> w;
        std::vector<double> cpu, mallocs;
        for (std::size_t k = 0; k < frames.size(); ++k) {
          ssm::FrameResult r;
          bool ok = false;
          const Sample s = measure([&] {
            ok = mapper.integrateFrame(dense_points_of[k], frames[k].T_fixed_left, frames[k].base,
                                       &r);
          });
          if (static_cast<int>(k) < opt.warmup || !ok) continue;
          w["integrate"].push_back(r.timings.integrate_ms);
          w["height_map"].push_back(r.timings.height_map_ms);
          w["segmentation"].push_back(r.timings.segmentation_ms);
          w["plane_fit"].push_back(r.timings.plane_fit_ms);
          w["labelling"].push_back(r.timings.labelling_ms);
          w["seg_fit_label"].push_back(r.timings.segmentation_ms + r.timings.plane_fit_ms +
                                       r.timings.labelling_ms);
          w["total"].push_back(r.timings.total_ms);
          cpu.push_back(s.cpu);
          mallocs.push_back(s.mallocs);
        }
        for (auto& kv : w)
          sp.wall_median[kv.first] = statsOf(kv.second).median;
        sp.cpu_total_median = statsOf(cpu).median;
        sp.mallocs_median = statsOf(mallocs).median;
        sp.frames = static_cast<int>(cpu.size());
      } catch (const std::exception& e) {
        sp.error = e.what();
        problems.push_back(sweep + " " + label + ": " + e.what());
      }
      scaling.push_back(sp);
    };
    progress("scaling: map size");
    for (double L : {5.0, 10.0, 20.0}) {
      ssm::SafetyMapperConfig c = pcfg.mapper;
      c.grid.size_x = c.grid.size_y = L;
      // The look-ahead must leave R_max behind the robot inside the window (safety_mapper.h).
      c.grid_look_ahead =
          std::min(c.grid_look_ahead, std::max(0.0, 0.5 * L - c.segmentation.planning_radius));
      mapperSweep("map_size", L, fmt(L, 0) + " x " + fmt(L, 0) + " x 3 m", c);
    }
    progress("scaling: voxel size");
    for (double lv : {0.05, 0.1, 0.2}) {
      ssm::SafetyMapperConfig c = pcfg.mapper;
      c.grid.voxel_size = lv;
      mapperSweep("voxel_size", lv, "l_v = " + fmt(lv, 2) + " m", c);
    }
  }
}

}  // namespace bench
