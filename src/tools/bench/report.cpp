// bench_pipeline's report: the targets, the Markdown tables (stdout) and bench.json. The keys and
// the layout of both are what scripts/bench, scripts/plot_bench.py and the README's Performance
// tables read: change them together.
#include "bench.h"

#include <opencv2/core/utility.hpp>

#include <sys/resource.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>

namespace bench {

void computeTargets(Bench* b) {
  auto& extra = b->extra;
  auto& pipeline_map = b->pipeline_map;
  auto& dense_map = b->dense_map;
  auto& targets = b->targets;
  const auto med = [b](const std::string& id, bool cpu) { return b->med(id, cpu); };
  // ---- targets ------------------------------------------------------------------------------
  {
    for (const char* prefix : {"voxel", "voxel_dense"}) {
      const std::string p = prefix;
      const std::string what =
          p == "voxel"
              ? "pipeline points, " + fmt(extra["voxel_points_median"], 0) + " points"
              : "dense SGBM points, " + fmt(extra["voxel_dense_points_median"], 0) + " points";
      Target t("voxel update, 640x480 frame (" + what + ")", "ms");
      t.wall = med(p + ".ours", false);
      t.cpu = med(p + ".ours", true);
      t.limit = 5.0;
      targets.push_back(t);
      for (const char* peer : {".octomap", ".octomap_discretize"}) {
        Target r(std::string("voxel update speed-up over ") +
                     (std::string(peer) == ".octomap" ? "insertPointCloud"
                                                      : "insertPointCloud(discretize)") +
                     " (" + (p == "voxel" ? "pipeline" : "dense") + " points)",
                 "x");
        r.wall = med(p + peer, false) / t.wall;
        r.cpu = med(p + peer, true) / t.cpu;
        r.limit = 10.0;
        r.at_most = false;
        targets.push_back(r);
      }
    }
    for (const MapStudy* st : {&pipeline_map, &dense_map}) {
      Target t("segmentation + plane fit + labelling, R_max = 4 m (" + st->what + ", " +
                   fmt(statsOf(st->segments).median, 0) + " segments)",
               "ms");
      t.wall = med("map" + st->suffix + ".seg_fit_label", false);
      t.cpu = med("map" + st->suffix + ".seg_fit_label", true);
      t.limit = 5.0;
      targets.push_back(t);
    }
    Target d("disparity + filters, BM, 640x480, 64 disparities", "ms");
    d.wall = med("disp.ours_bm", false);
    d.cpu = med("disp.ours_bm", true);
    d.limit = 33.0;
    targets.push_back(d);
    // Issue 18: the stage with every post-filter against the bare OpenCV matcher, same frames,
    // same run (interleaved frame by frame).
    for (const auto& m : {std::make_pair("BM", "bm"), std::make_pair("SGBM", "sgbm")}) {
      const std::string ours = std::string("disp.ours_") + m.second;
      const std::string peer = std::string("disp.opencv_") + m.second;
      Target r(std::string("disparity ") + m.first + " + all filters / OpenCV Stereo" + m.first +
                   " alone (same frames, same run)",
               "x");
      r.wall = med(ours, false) / med(peer, false);
      r.cpu = med(ours, true) / med(peer, true);
      r.limit = 1.3;
      r.limit_digits = 1;
      targets.push_back(r);
    }
    // The SGBM ratio with the left-right check's cheaper modes (issue 18; not bit for bit).
    for (const auto& m : {std::make_pair("half", "disp.ours_sgbm_half"),
                          std::make_pair("opencv", "disp.ours_sgbm_opencv")}) {
      if (std::isnan(med(m.second, false))) continue;  // not measured
      Target r(std::string("disparity SGBM + all filters, left_right_mode ") + m.first +
                   " / OpenCV StereoSGBM alone (same frames, same run)",
               "x");
      r.wall = med(m.second, false) / med("disp.opencv_sgbm", false);
      r.cpu = med(m.second, true) / med("disp.opencv_sgbm", true);
      r.limit = 1.3;
      r.limit_digits = 1;
      targets.push_back(r);
    }
  }
}

void printMarkdown(Bench* b) {
  const Options& opt = b->opt;
  auto& sf = b->sf;
  auto& poses = b->poses;
  auto& chosen = b->chosen;
  auto& measured = b->measured;
  auto& t_start = b->t_start;
  auto& load_start = b->load_start;
  auto& load_end = b->load_end;
  auto& rss_start = b->rss_start;
  auto& rss_end = b->rss_end;
  auto& rss_peak = b->rss_peak;
  auto& run_s = b->run_s;
  auto& proc_cpu_s = b->proc_cpu_s;
  auto& pinned_cpu = b->pinned_cpu;
  auto& reg = b->reg;
  auto& comparisons = b->comparisons;
  auto& extra = b->extra;
  auto& pending = b->pending;
  auto& not_integrated = b->not_integrated;
  auto& pipeline_map = b->pipeline_map;
  auto& dense_map = b->dense_map;
  auto& density = b->density;
  auto& disparity_allocs = b->disparity_allocs;
  auto& scaling = b->scaling;
  auto& targets = b->targets;
  const auto med = [b](const std::string& id, bool cpu) { return b->med(id, cpu); };
  // ---- output: Markdown ---------------------------------------------------------------------
  load_end = readFirstLine("/proc/loadavg");
  run_s = (wallMs() - t_start) / 1e3;
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  proc_cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
               1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);

  std::printf("# bench_pipeline%s\n\n",
              opt.quick ? " (--quick smoke: too few frames to quote)" : "");
  std::printf(
      "Input: %s, %zu measured + %d warm-up frames at 640x480 (moving frames %zu..%zu of %zu, "
      "stride %d), %.0f points/frame after reprojection (dense SGBM input: %.0f points, %.0f rays "
      "cast after one-point-per-voxel). Machine: %s, %ld cores, load average "
      "%s at start, %s at end; measuring thread %s; cv::setNumThreads(1). Run %.0f s.\n\n",
      sf.scene.name.c_str(), measured.size(), opt.warmup, chosen.front(), chosen.back(),
      poses.size(), opt.stride, extra["points_per_frame_mean"], extra["voxel_dense_points_median"],
      extra["voxel_dense_rays_median"], cpuModel().c_str(), sysconf(_SC_NPROCESSORS_ONLN),
      load_start.c_str(), load_end.c_str(),
      pinned_cpu >= 0 ? ("pinned to core " + std::to_string(pinned_cpu)).c_str() : "not pinned",
      run_s);

  std::printf("## Stages\n\n");
  std::printf(
      "| stage | impl | n | wall min | wall median | wall max | CPU median | allocs/call (median) "
      "|\n|---|---|---|---|---|---|---|---|\n");
  std::string last_group;
  for (const Series& s : reg.all()) {
    if (s.group != last_group) {
      std::printf("| **%s** | | | | | | | |\n", s.group.c_str());
      last_group = s.group;
    }
    const Stats w = statsOf(s.wall), c = statsOf(s.cpu), a = statsOf(s.mallocs),
                n = statsOf(s.news);
    std::string allocs = "—";
    if (a.n > 0) {
      allocs = SSM_BENCH_COUNT_MALLOC ? fmt(a.median, 0) + " (new " + fmt(n.median, 0) + ")"
                                      : "new " + fmt(n.median, 0);
    }
    std::printf("| %s | %s | %d | %s | %s | %s | %s | %s |\n", s.label.c_str(), s.impl.c_str(), w.n,
                fmt(w.min).c_str(), fmt(w.median).c_str(), fmt(w.max).c_str(),
                fmt(c.median).c_str(), allocs.c_str());
  }
  std::printf(
      "\nTimes in ms. allocs = malloc-family calls (OpenCV buffers included), new = C++ "
      "operator new calls.\n\n");

  std::printf("## Ours vs peers (same run, identical input)\n\n");
  std::printf(
      "| comparison | ours | peer | ours median | peer median | peer / ours (wall) | peer / ours "
      "(CPU) |\n|---|---|---|---|---|---|---|\n");
  for (const Comparison& c : comparisons) {
    const Series* a = reg.find(c.ours);
    const Series* b = reg.find(c.peer);
    if (a == nullptr || b == nullptr) continue;
    std::printf("| %s | %s | %s | %s | %s | %s | %s |\n", c.what.c_str(), a->label.c_str(),
                b->label.c_str(), fmt(med(c.ours, false)).c_str(), fmt(med(c.peer, false)).c_str(),
                fmt(med(c.peer, false) / med(c.ours, false)).c_str(),
                fmt(med(c.peer, true) / med(c.ours, true)).c_str());
  }
  std::printf("\npeer / ours > 1: ours is faster by that factor.\n\n");

  std::printf("## Targets (medians, one core; reported, not asserted)\n\n");
  std::printf(
      "| target | wall | CPU | limit | met (wall) | met (CPU) |\n|---|---|---|---|---|---|\n");
  for (const Target& t : targets) {
    const char* op = t.at_most ? "<=" : ">=";
    std::printf("| %s | %s %s | %s %s | %s %s %s | %s | %s |\n", t.name.c_str(),
                fmt(t.wall).c_str(), t.unit.c_str(), fmt(t.cpu).c_str(), t.unit.c_str(), op,
                fmt(t.limit, t.limit_digits).c_str(), t.unit.c_str(),
                t.metBy(t.wall) ? "yes" : "NO",
                std::isfinite(t.cpu) ? (t.metBy(t.cpu) ? "yes" : "NO") : "—");
  }
  std::printf(
      "\nSGBM (package defaults, block 9, MODE_SGBM) + all filters, 640x480: median %s ms "
      "wall, %s ms CPU.\n",
      fmt(med("disp.ours_sgbm", false)).c_str(), fmt(med("disp.ours_sgbm", true)).c_str());
  std::printf("Disparity density (valid pixels, frame 1):");
  for (const auto& kv : density)
    std::printf(" %s %.1f %%;", kv.first.c_str(), 100.0 * kv.second.front());
  std::printf("\n");
  for (const MapStudy* st : {&pipeline_map, &dense_map}) {
    std::printf(
        "Map state (%s) over the measured frames: %s columns with a height (median), %s "
        "segments (median, max %s), robot's seed found in %s %% of the frames. Largest "
        "segment: %s points (median); our plane normal and PCL's differ by %s deg "
        "(median, max %s); PCL inliers %s %% (median).\n",
        st->what.c_str(), fmt(statsOf(st->columns).median, 0).c_str(),
        fmt(statsOf(st->segments).median, 0).c_str(), fmt(statsOf(st->segments).max, 0).c_str(),
        fmt(100.0 * fractionOf(st->seed), 0).c_str(),
        fmt(statsOf(st->fit_points).median, 0).c_str(), fmt(statsOf(st->fit_angle).median).c_str(),
        fmt(statsOf(st->fit_angle).max).c_str(),
        fmt(100.0 * statsOf(st->inlier_fraction).median, 1).c_str());
  }
  if (opt.quick) {
    std::printf("(--quick: the dense map uses singleFrameMapperConfig, occ_t = incr_H.)\n");
  }
  std::printf("PCL SACSegmentation: default max iterations (50), optimise coefficients on.\n\n");

  if (!scaling.empty()) {
    std::printf("## Scaling (median wall ms per frame; CPU = thread CPU of the whole call)\n\n");
    for (const char* sweep : {"image_size", "map_size", "voxel_size"}) {
      const bool img = std::string(sweep) == "image_size";
      std::printf(
          "%s\n\n",
          img ? "Image size (whole pipeline, BM + filters):"
              : (std::string(sweep) == "map_size"
                     ? "Map size (mapper only, dense 640x480 SGBM points, l_v 0.1 m):"
                     : "Voxel size (mapper only, dense 640x480 SGBM points, 10 x 10 x 3 m):"));
      if (img) {
        std::printf(
            "| size | frames | points | disparity | reproject | integrate | seg+fit+label "
            "| total | CPU total | allocs |\n|---|---|---|---|---|---|---|---|---|---|\n");
      } else {
        std::printf(
            "| config | frames | integrate | height map | segmentation | plane fit | "
            "labelling | total | CPU total | allocs |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n");
      }
      for (const ScalingPoint& sp : scaling) {
        if (sp.sweep != sweep) continue;
        auto g = [&](const char* k) {
          auto it = sp.wall_median.find(k);
          return fmt(it == sp.wall_median.end() ? std::numeric_limits<double>::quiet_NaN()
                                                : it->second);
        };
        if (!sp.error.empty()) {
          std::printf("| %s | error: %s |\n", sp.label.c_str(), sp.error.c_str());
        } else if (img) {
          std::printf("| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s |\n", sp.label.c_str(),
                      sp.frames, fmt(sp.points_median, 0).c_str(), g("disparity").c_str(),
                      g("reproject").c_str(), g("integrate").c_str(), g("seg_fit_label").c_str(),
                      g("total").c_str(), fmt(sp.cpu_total_median).c_str(),
                      fmt(sp.mallocs_median, 0).c_str());
        } else {
          std::printf("| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s |\n", sp.label.c_str(),
                      sp.frames, g("integrate").c_str(), g("height_map").c_str(),
                      g("segmentation").c_str(), g("plane_fit").c_str(), g("labelling").c_str(),
                      g("total").c_str(), fmt(sp.cpu_total_median).c_str(),
                      fmt(sp.mallocs_median, 0).c_str());
        }
      }
      std::printf("\n");
    }
  }

  rss_end = rssMb();
  rss_peak = peakRssMb();
  std::printf("## Memory\n\n");
  std::printf("| quantity | value |\n|---|---|\n");
  auto allocLine = [&](const char* what, const char* id) {
    const Series* s = reg.find(id);
    if (s == nullptr || s->news.empty()) return;
    const Stats a = statsOf(s->mallocs), n = statsOf(s->news);
    if (SSM_BENCH_COUNT_MALLOC) {
      std::printf(
          "| allocations per call, %s | median %s, max %s (operator new: median %s, max "
          "%s) |\n",
          what, fmt(a.median, 0).c_str(), fmt(a.max, 0).c_str(), fmt(n.median, 0).c_str(),
          fmt(n.max, 0).c_str());
    } else {
      std::printf("| operator new calls per call, %s | median %s, max %s |\n", what,
                  fmt(n.median, 0).c_str(), fmt(n.max, 0).c_str());
    }
  };
  allocLine("VoxelGrid::integrate (pipeline points)", "voxel.ours");
  allocLine("VoxelGrid::integrate (dense points)", "voxel_dense.ours");
  allocLine("VoxelGrid::recenter", "voxel.ours_recenter");
  allocLine("DisparityPipeline::compute (BM + filters)", "disp.ours_bm");
  if (!disparity_allocs.empty()) {
    std::printf("| DisparityPipeline allocations per call by configuration (malloc / new) |");
    for (const auto& da : disparity_allocs)
      std::printf(" %s: %s / %s;", da.first.c_str(), fmt(da.second.mallocs, 0).c_str(),
                  fmt(da.second.news, 0).c_str());
    std::printf(" |\n");
  }
  allocLine("segmentation + plane fit + labelling (pipeline map)", "map.seg_fit_label");
  allocLine("segmentation + plane fit + labelling (dense map)", "map_dense.seg_fit_label");
  allocLine("SafetyMapper::integrateFrame (dense map)", "mapper_dense.frame");
  allocLine("whole frame (processImages)", "pipeline.frame");
  allocLine("OcTree::insertPointCloud", "voxel.octomap");
  std::printf("| VoxelGrid storage (10 x 10 x 3 m, 0.1 m, 8 points/voxel), allocated | %s MB |\n",
              fmt(extra["voxel_grid_bytes"] / 1048576.0, 1).c_str());
  for (const char* prefix : {"voxel", "voxel_dense"}) {
    const std::string p = prefix;
    std::printf(
        "| OcTree memoryUsage() after the %s run (plain / discretize) | %s / %s MB, %.0f "
        "nodes |\n",
        p == "voxel" ? "pipeline-points" : "dense-points",
        fmt(extra[p + "_octomap_bytes"] / 1048576.0, 1).c_str(),
        fmt(extra[p + "_octomap_discretize_bytes"] / 1048576.0, 1).c_str(),
        extra[p + "_octomap_nodes"]);
  }
  std::printf("| process RSS at start / end / peak | %s / %s / %s MB |\n",
              fmt(rss_start, 0).c_str(), fmt(rss_end, 0).c_str(), fmt(rss_peak, 0).c_str());
  std::printf("\n");

  pending.push_back(
      "30-minute memory run (RSS over time): scripts/soak (long looped replays through "
      "bag_replay.launch, the manager's memory sampled)");
  std::printf("## Not measured in this run\n\n");
  for (const std::string& p : pending)
    std::printf("- %s\n", p.c_str());
  if (not_integrated > 0)
    std::printf("- %d frame(s) were not integrated (see stderr)\n", not_integrated);
  std::printf("\n");
}

bool writeJson(Bench* b, int argc, char** argv) {
  const Options& opt = b->opt;
  auto& sf = b->sf;
  auto& head = b->head;
  auto& frames = b->frames;
  auto& measured = b->measured;
  auto& render_s = b->render_s;
  auto& load_start = b->load_start;
  auto& load_end = b->load_end;
  auto& rss_start = b->rss_start;
  auto& rss_end = b->rss_end;
  auto& rss_peak = b->rss_peak;
  auto& run_s = b->run_s;
  auto& proc_cpu_s = b->proc_cpu_s;
  auto& pinned_cpu = b->pinned_cpu;
  auto& reg = b->reg;
  auto& comparisons = b->comparisons;
  auto& extra = b->extra;
  auto& problems = b->problems;
  auto& pending = b->pending;
  auto& not_integrated = b->not_integrated;
  auto& pipeline_map = b->pipeline_map;
  auto& dense_map = b->dense_map;
  auto& density = b->density;
  auto& disparity_allocs = b->disparity_allocs;
  auto& scaling = b->scaling;
  auto& targets = b->targets;
  const auto med = [b](const std::string& id, bool cpu) { return b->med(id, cpu); };
  // ---- output: JSON -------------------------------------------------------------------------
  {
    Json j(true);
    j.open('{');
    std::string cmdline;
    for (int i = 0; i < argc; ++i)
      cmdline += (i ? " " : "") + std::string(argv[i]);
    j.kv("tool", "bench_pipeline").kv("schema", 1).kv("quick", opt.quick);
    j.kv("command", cmdline);
    j.key("machine")
        .open('{')
        .kv("cpu_model", cpuModel())
        .kv("cores_online", sysconf(_SC_NPROCESSORS_ONLN))
        .kv("loadavg_start", load_start)
        .kv("loadavg_end", load_end)
        .kv("pinned_cpu", pinned_cpu)
        .kv("cv_threads", cv::getNumThreads())
        .kv("opencv", CV_VERSION)
        .kv("compiler", __VERSION__)
#ifdef NDEBUG
        .kv("ndebug", true)
#else
        .kv("ndebug", false)
#endif
        .kv("malloc_counted", SSM_BENCH_COUNT_MALLOC != 0)
        .kv("time", isoTime());
    {
      utsname u{};
      if (uname(&u) == 0) j.kv("kernel", std::string(u.sysname) + " " + u.release);
    }
    j.kv("run_s", run_s).kv("render_s", render_s).kv("process_cpu_s", proc_cpu_s);
    j.close('}');
    j.key("input")
        .open('{')
        .kv("scene", sf.scene.name)
        .kv("scene_file", opt.scene)
        .kv("width", head.width)
        .kv("height", head.height)
        .kv("measured_frames", static_cast<long long>(measured.size()))
        .kv("warmup_frames", opt.warmup)
        .kv("stride", opt.stride)
        .kv("passes", opt.passes)
        .kv("points_per_frame_mean", extra["points_per_frame_mean"])
        .kv("voxel_points_median", extra["voxel_points_median"])
        .kv("voxel_rays_median", extra["voxel_rays_median"])
        .kv("voxel_dense_points_median", extra["voxel_dense_points_median"])
        .kv("voxel_dense_rays_median", extra["voxel_dense_rays_median"])
        .kv("frames_not_integrated", not_integrated);
    j.key("frame_indices").open('[');
    for (const Frame& f : frames)
      j.val(static_cast<double>(f.index));
    j.close(']').close('}');
    j.key("stages").open('[');
    for (const Series& s : reg.all()) {
      j.open('{').kv("id", s.id).kv("group", s.group).kv("label", s.label).kv("impl", s.impl);
      if (!s.note.empty()) j.kv("note", s.note);
      writeStats(j, "wall_ms", statsOf(s.wall));
      writeStats(j, "cpu_ms", statsOf(s.cpu));
      writeStats(j, "new_per_call", statsOf(s.news));
      if (SSM_BENCH_COUNT_MALLOC) {
        writeStats(j, "allocs_per_call", statsOf(s.mallocs));
      } else {
        j.key("allocs_per_call").null();
      }
      j.close('}');
    }
    j.close(']');
    j.key("comparisons").open('[');
    for (const Comparison& c : comparisons) {
      if (reg.find(c.ours) == nullptr || reg.find(c.peer) == nullptr) continue;
      j.open('{')
          .kv("what", c.what)
          .kv("ours", c.ours)
          .kv("peer", c.peer)
          .kv("ours_median_ms", med(c.ours, false))
          .kv("peer_median_ms", med(c.peer, false))
          .kv("peer_over_ours_wall", med(c.peer, false) / med(c.ours, false))
          .kv("peer_over_ours_cpu", med(c.peer, true) / med(c.ours, true))
          .close('}');
    }
    j.close(']');
    j.key("targets").open('[');
    for (const Target& t : targets) {
      j.open('{')
          .kv("name", t.name)
          .kv("unit", t.unit)
          .kv("wall", t.wall)
          .kv("cpu", t.cpu)
          .kv("op", t.at_most ? "<=" : ">=")
          .kv("limit", t.limit)
          .kv("met_wall", t.metBy(t.wall));
      if (std::isfinite(t.cpu)) {
        j.kv("met_cpu", t.metBy(t.cpu));
      } else {
        j.key("met_cpu").null();
      }
      if (!t.note.empty()) j.kv("note", t.note);
      j.close('}');
    }
    j.close(']');
    j.key("sgbm").open('{').kv("wall_median_ms", med("disp.ours_sgbm", false));
    j.kv("cpu_median_ms", med("disp.ours_sgbm", true)).close('}');
    j.key("disparity_density").open('{');
    for (const auto& kv : density)
      j.kv(kv.first, kv.second.front());
    j.close('}');
    j.key("maps").open('[');
    for (const MapStudy* st : {&pipeline_map, &dense_map}) {
      j.open('{')
          .kv("map", st->what)
          .kv("suffix", st->suffix)
          .kv("columns_with_height_median", statsOf(st->columns).median)
          .kv("segments_median", statsOf(st->segments).median)
          .kv("segments_max", statsOf(st->segments).max)
          .kv("robot_seed_found_fraction", fractionOf(st->seed))
          .kv("largest_segment_points_median", statsOf(st->fit_points).median)
          .kv("normal_angle_vs_pcl_deg_median", statsOf(st->fit_angle).median)
          .kv("normal_angle_vs_pcl_deg_max", statsOf(st->fit_angle).max)
          .kv("pcl_inlier_fraction_median", statsOf(st->inlier_fraction).median)
          .close('}');
    }
    j.close(']');
    j.kv("dense_map_single_frame_config", opt.quick);
    j.key("scaling").open('[');
    for (const ScalingPoint& sp : scaling) {
      j.open('{').kv("sweep", sp.sweep).kv("x", sp.x).kv("label", sp.label).kv("frames", sp.frames);
      if (!sp.error.empty()) j.kv("error", sp.error);
      j.key("wall_median_ms").open('{');
      for (const auto& kv : sp.wall_median)
        j.kv(kv.first, kv.second);
      j.close('}');
      j.kv("cpu_total_median_ms", sp.cpu_total_median)
          .kv("points_median", sp.points_median)
          .kv("allocs_median", sp.mallocs_median)
          .close('}');
    }
    j.close(']');
    j.key("memory")
        .open('{')
        .kv("rss_start_mb", rss_start)
        .kv("rss_end_mb", rss_end)
        .kv("rss_peak_mb", rss_peak)
        .kv("voxel_grid_bytes", extra["voxel_grid_bytes"])
        .kv("octomap_bytes", extra["voxel_octomap_bytes"])
        .kv("octomap_discretize_bytes", extra["voxel_octomap_discretize_bytes"])
        .kv("octomap_nodes", extra["voxel_octomap_nodes"])
        .kv("dense_octomap_bytes", extra["voxel_dense_octomap_bytes"])
        .kv("dense_octomap_discretize_bytes", extra["voxel_dense_octomap_discretize_bytes"])
        .kv("dense_octomap_nodes", extra["voxel_dense_octomap_nodes"])
        .close('}');
    j.key("disparity_allocs_by_config").open('[');
    for (const auto& da : disparity_allocs) {
      j.open('{')
          .kv("config", da.first)
          .kv("allocs",
              SSM_BENCH_COUNT_MALLOC ? da.second.mallocs : std::numeric_limits<double>::quiet_NaN())
          .kv("new", da.second.news)
          .close('}');
    }
    j.close(']');
    j.key("pending").open('[');
    for (const std::string& p : pending)
      j.val(p);
    j.close(']');
    j.key("problems").open('[');
    for (const std::string& p : problems)
      j.val(p);
    j.close(']');
    j.close('}');
    std::ofstream out(opt.json);
    out << j.str() << "\n";
    if (!out) {
      std::fprintf(stderr, "bench_pipeline: cannot write %s\n", opt.json.c_str());
      return false;
    }
    progress("wrote %s", opt.json.c_str());
  }
  return true;
}

}  // namespace bench
