// evaluate_safety_map: output. The per-frame CSVs, metrics.json (tools/json.h) and report.md.
#include "evaluate_safety_map.h"

#include "stereo_safety_map/tools/json.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace evaluate_safety_map {

std::string writeFrameCsv(const std::string& path, const DatasetResult& r, const std::string& run) {
  std::ofstream f(path);
  if (!f) return "cannot write " + path;
  f << "# " << r.name << " " << run << ": one row per stereo pair\n";
  f << "frame,stamp,status,robot_segment,tp,fp,fn,tn,unclassified_in_map,unclassified_in_gt,points";
  for (const char* s : kStageNames)
    f << "," << s << "_ms";
  for (const auto& l : r.latency)
    f << ",coverage_" << l.board;
  f << "\n" << std::setprecision(10);
  for (std::size_t i = 0; i < r.frames.size(); ++i) {
    const FrameRecord& fr = r.frames[i];
    f << fr.index << "," << fr.stamp << "," << fr.status << "," << (fr.robot_segment ? 1 : 0) << ","
      << fr.counts.tp << "," << fr.counts.fp << "," << fr.counts.fn << "," << fr.counts.tn << ","
      << fr.counts.unclassified_in_map << "," << fr.counts.unclassified_in_gt << "," << fr.points;
    f << std::setprecision(4);
    for (double m : fr.ms)
      f << "," << m;
    for (const auto& l : r.latency) {
      const int k = static_cast<int>(i) - l.appear_frame;
      f << ",";
      if (l.appear_frame >= 0 && k >= 0 && k < static_cast<int>(l.coverage.size()))
        f << l.coverage[k];
    }
    f << std::setprecision(10) << "\n";
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Output: JSON and Markdown

using stereo_safety_map::tools::Json;  // tool_support/json.h

void jsonMeanStd(Json& j, const std::string& k, const ssm::MeanStd& m) {
  j.key(k).open('{').kv("mean", m.mean).kv("std", m.stddev).kv("n", m.n).close('}');
}

void jsonCounts(Json& j, const std::string& k, const ssm::ConfusionCounts& c) {
  j.key(k).open('{');
  j.kv("tp", c.tp).kv("fp", c.fp).kv("fn", c.fn).kv("tn", c.tn);
  j.kv("unsafe_cells", c.unsafeCells()).kv("safe_cells", c.safeCells());
  j.kv("unclassified_in_map", c.unclassified_in_map).kv("unclassified_in_gt", c.unclassified_in_gt);
  j.kv("maps", c.maps).close('}');
}

void jsonRates(Json& j, const std::string& k, const ssm::ConfusionCounts& c) {
  const ssm::ErrorRates r = ssm::errorRates(c);
  const ssm::SafeClassScores s = ssm::safeClassScores(c);
  j.key(k).open('{').kv("fn", r.fn).kv("fp", r.fp).kv("tp", r.tp).kv("tn", r.tn);
  j.kv("precision", s.precision).kv("recall", s.recall).kv("f1", s.f1).close('}');
}

void jsonTimings(Json& j, const Series* stage_ms) {
  j.key("timings_ms").open('{');
  for (int k = 0; k < kStages; ++k) {
    j.key(kStageNames[k]).open('{');
    j.kv("mean", stage_ms[k].mean()).kv("median", stage_ms[k].quantile(0.5));
    j.kv("p90", stage_ms[k].quantile(0.9)).kv("max", stage_ms[k].max()).close('}');
  }
  j.close('}');
}

double share(std::uint64_t part, std::uint64_t whole) {
  return whole == 0 ? kNaN : static_cast<double>(part) / static_cast<double>(whole);
}

std::string fmtPct(double v) {
  if (!std::isfinite(v)) return "n/a";
  char b[32];
  std::snprintf(b, sizeof(b), "%.1f", 100 * v);
  return b;
}
std::string fmtPm(const ssm::MeanStd& m, double scale, int prec) {
  if (!std::isfinite(m.mean)) return "n/a";
  char b[64];
  std::snprintf(b, sizeof(b), "%.*f +- %.*f", prec, scale * m.mean, prec,
                std::isfinite(m.stddev) ? scale * m.stddev : 0.0);
  return b;
}
std::string fmt(double v, int prec = 1) {
  if (!std::isfinite(v)) return "n/a";
  char b[32];
  std::snprintf(b, sizeof(b), "%.*f", prec, v);
  return b;
}

std::string writeOutputs(const Options& opt, const ssm::StereoFrameProcessorConfig& config,
                         const std::vector<Run>& runs, const std::string& command) {
  const std::vector<Target> tg = targets(runs);
  // ---- JSON
  Json j;
  j.open('{');
  j.kv("tool", "evaluate_safety_map").kv("command", command);
  j.kv("mode", opt.recorded.empty() ? "offline" : "recorded");
  j.key("config").open('{');
  const auto& g = config.mapper.grid;
  j.kv("voxel_size", g.voxel_size).kv("incr_high", g.incr_high).kv("incr_low", g.incr_low);
  j.kv("occ_threshold", g.occ_threshold)
      .kv("planning_radius", config.mapper.segmentation.planning_radius);
  j.kv("seed_radius", config.mapper.segmentation.seed_radius);
  j.kv("every", opt.every).kv("disparity_step", config.disparity_step);
  j.kv("matcher",
       config.disparity.matcher == ssm::StereoMatcherType::kBlockMatching ? "BM" : "SGBM");
  j.kv("texture_filter", config.disparity.enable_texture);
  j.kv("plane_frames", opt.plane_frames).kv("seed", static_cast<int>(opt.seed));
  j.key("params_files").open('[');
  for (const std::string& p : opt.params)
    j.val(p);
  j.close(']');
  j.key("set").open('[');
  for (const std::string& a : opt.sets)
    j.val(a);
  j.close(']');
  j.close('}');
  j.key("runs").open('[');
  for (const Run& run : runs) {
    const RunSummary s = summarize(run);
    j.open('{').kv("label", run.label).kv("decr", run.decr);
    j.key("summary").open('{');
    j.kv("datasets", s.datasets)
        .kv("maps", s.maps)
        .kv("maps_without_robot_segment", s.without_robot_segment);
    jsonMeanStd(j, "fn", s.fn);
    jsonMeanStd(j, "fp", s.fp);
    jsonMeanStd(j, "tp", s.tp);
    jsonMeanStd(j, "tn", s.tn);
    jsonMeanStd(j, "precision", s.precision);
    jsonMeanStd(j, "recall", s.recall);
    jsonMeanStd(j, "f1", s.f1);
    jsonMeanStd(j, "fn_with_robot_segment", s.seeded_fn);
    jsonMeanStd(j, "fp_with_robot_segment", s.seeded_fp);
    jsonMeanStd(j, "fn_local_horizon", s.local_fn);
    jsonMeanStd(j, "fp_local_horizon", s.local_fp);
    j.key("planes_protocol").open('{');
    jsonMeanStd(j, "angle_deg", s.planes_protocol.angle);
    jsonMeanStd(j, "distance_m", s.planes_protocol.distance);
    j.close('}');
    j.key("planes_all_frames").open('{');
    jsonMeanStd(j, "angle_deg", s.planes_all.angle);
    jsonMeanStd(j, "distance_m", s.planes_all.distance);
    j.close('}');
    jsonTimings(j, s.stage_ms);
    j.kv("bag_seconds", s.bag_seconds).kv("wall_seconds", s.wall_seconds);
    j.kv("realtime_factor", s.wall_seconds > 0 ? s.bag_seconds / s.wall_seconds : kNaN);
    j.close('}');
    j.key("datasets").open('[');
    for (const DatasetResult& d : run.datasets) {
      j.open('{').kv("name", d.name).kv("latency_only", d.latency_only);
      j.kv("pairs", d.pairs).kv("maps", d.integrated).kv("stationary", d.stationary);
      j.kv("rejected", d.rejected).kv("maps_without_robot_segment", d.without_robot_segment);
      j.key("fp_where").open('{');
      j.kv("ground_segment_labelled_non_ground", d.fp_in_segment);
      j.kv("column_in_no_segment", d.fp_no_segment);
      j.kv("maps_without_robot_segment", d.fp_without_robot_segment).close('}');
      jsonCounts(j, "counts", d.sum);
      jsonRates(j, "rates", d.sum);
      jsonCounts(j, "counts_with_robot_segment", d.seeded);
      jsonRates(j, "rates_with_robot_segment", d.seeded);
      j.kv("local_horizon_maps", d.local_maps);
      jsonCounts(j, "counts_local_horizon", d.local);
      jsonRates(j, "rates_local_horizon", d.local);
      const PlaneSummary pp = summarize(d.planes_protocol), pa = summarize(d.planes_all);
      j.key("planes_protocol").open('{');
      j.key("frames").open('[');
      for (int f : d.protocol_frames)
        j.val(f);
      j.close(']');
      jsonMeanStd(j, "angle_deg", pp.angle);
      jsonMeanStd(j, "distance_m", pp.distance);
      j.key("planes").open('[');
      for (const PlaneSample& p : d.planes_protocol) {
        j.open('{').kv("frame", p.frame).kv("reference", p.reference).kv("angle_deg", p.angle_deg);
        j.kv("distance_m", p.distance)
            .kv("cells", p.cells)
            .kv("label", ssm::toString(p.label))
            .close('}');
      }
      j.close(']').close('}');
      j.key("planes_all_frames").open('{');
      jsonMeanStd(j, "angle_deg", pa.angle);
      jsonMeanStd(j, "distance_m", pa.distance);
      j.close('}');
      j.key("latency").open('[');
      for (const LatencyResult& l : d.latency) {
        j.open('{').kv("board", l.board).kv("start_distance_m", l.start_distance);
        j.kv("textured", d.name.find("untextured") == std::string::npos);
        j.kv("appear_frame", l.appear_frame).kv("frames_available", l.frames_available);
        j.kv("frames_to_50", l.frames_to_50).kv("frames_to_90", l.frames_to_90);
        j.kv("final_coverage", l.coverage.empty() ? kNaN : l.coverage.back()).close('}');
      }
      j.close(']');
      jsonTimings(j, d.stage_ms);
      j.kv("bag_seconds", d.bag_seconds).kv("wall_seconds", d.wall_seconds);
      j.key("images").open('[');
      for (const auto& im : d.images)
        j.val(im);
      j.close(']');
      j.key("problems").open('{');
      for (const auto& p : d.problems)
        j.kv(p.first, p.second);
      j.close('}');
      j.close('}');
    }
    j.close(']').close('}');
  }
  j.close(']');
  j.key("targets").open('[');
  for (const Target& t : tg) {
    j.open('{').kv("name", t.name).kv("measured", t.measured).kv("limit", t.limit);
    j.kv("unit", t.unit).kv("paper", t.paper).kv("pass", t.pass()).close('}');
  }
  j.close(']');
  j.close('}');
  {
    std::ofstream f(opt.out + "/metrics.json");
    if (!f) return "cannot write " + opt.out + "/metrics.json";
    f << j.str() << "\n";
  }

  // ---- Markdown
  std::ostringstream md;
  md << "# Safety map evaluation\n\n"
     << "Made by `" << command << "` ("
     << (opt.recorded.empty() ? "offline: the core pipeline "
                                "on the bags, no roscore"
                              : "recorded: maps published by the nodelets")
     << "). Definitions: docs/evaluation.md. Rates in percent; unsafe (Non-ground) is the "
        "positive class (000 Sec. VII-A); precision / recall / F1 are of the safe class "
        "(001 Sec. 5).\n\n";
  if (!tg.empty()) {
    md << "## Targets\n\n| target | measured | limit | paper | |\n|---|---|---|---|---|\n";
    for (const Target& t : tg)
      md << "| " << t.name << " | " << fmt(t.measured, 2) << " " << t.unit
         << " | <= " << fmt(t.limit, 1) << " " << t.unit << " | " << t.paper << " | "
         << (t.pass() ? "met" : "**missed**") << " |\n";
    md << "\n";
  }
  // Table II.
  bool any_rates = false;
  for (const Run& r : runs)
    any_rates = any_rates || summarize(r).datasets > 0;
  if (any_rates) {
    md << "## Error rates averaged over datasets (000 Table II)\n\n| | ";
    for (const Run& r : runs)
      md << r.label << " | ";
    md << "\n|---|";
    for (std::size_t i = 0; i < runs.size(); ++i)
      md << "---|";
    md << "\n";
    const char* rows[] = {"False negative rate (FN)",
                          "False positive rate (FP)",
                          "True positive rate (TP)",
                          "True negative rate (TN)",
                          "Precision (safe, 001)",
                          "Recall (safe, 001)",
                          "F1 (safe, 001)",
                          "FN, maps with the robot's segment",
                          "FP, maps with the robot's segment",
                          "FN, local-horizon GT",
                          "FP, local-horizon GT"};
    for (int row = 0; row < 11; ++row) {
      md << "| " << rows[row] << " | ";
      for (const Run& r : runs) {
        const RunSummary s = summarize(r);
        const ssm::MeanStd* m[] = {&s.fn,        &s.fp,       &s.tp,      &s.tn,
                                   &s.precision, &s.recall,   &s.f1,      &s.seeded_fn,
                                   &s.seeded_fp, &s.local_fn, &s.local_fp};
        md << (row >= 4 && row <= 6 ? fmtPm(*m[row], 1.0, 3) : fmtPm(*m[row], 100.0)) << " | ";
      }
      md << "\n";
    }
    md << "\nPaper (decr 1 / 3 / 5): FN 3.0 / 8.5 / 11.2, FP 9.3 / 6.2 / 5.2, TP 97.0 / 91.5 / "
          "88.8, "
          "TN 90.7 / 93.8 / 94.8. ROC curve: fig6a_roc.png (scripts/plot_evaluation.py).\n\n"
          "The rates above compare with the dataset's GT map, whose reachability is that of the "
          "whole scene from the robot's start (a lower level reached by a ramp far ahead is "
          "safe). The local-horizon rows compare the same maps with the scene's GT relabelled "
          "at each frame with reachability from the robot's position within R_max, i.e. with "
          "what the robot could know; the difference is the share of errors that only a look "
          "beyond R_max could avoid.\n\n";
    for (const Run& r : runs) {
      md << "### Per dataset, " << r.label << "\n\n"
         << "| dataset | maps | stationary | no robot segment | unsafe cells | safe cells | FN | "
            "FP | "
            "TP | TN | P | R | F1 | FP in Non-ground segments / in no segment / in maps without "
            "robot segment [%] |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
      for (const DatasetResult& d : r.datasets) {
        if (d.latency_only) continue;
        const ssm::ErrorRates e = ssm::errorRates(d.sum);
        const ssm::SafeClassScores c = ssm::safeClassScores(d.sum);
        md << "| " << d.name << " | " << d.integrated << " | " << d.stationary << " | "
           << d.without_robot_segment << " | " << d.sum.unsafeCells() << " | " << d.sum.safeCells()
           << " | " << fmtPct(e.fn) << " | " << fmtPct(e.fp) << " | " << fmtPct(e.tp) << " | "
           << fmtPct(e.tn) << " | " << fmt(c.precision, 3) << " | " << fmt(c.recall, 3) << " | "
           << fmt(c.f1, 3) << " | " << fmtPct(share(d.fp_in_segment, d.sum.fp)) << " / "
           << fmtPct(share(d.fp_no_segment, d.sum.fp)) << " / "
           << fmtPct(share(d.fp_without_robot_segment, d.sum.fp)) << " |\n";
      }
      md << "\n";
    }
    // Planes.
    md << "## Plane accuracy (000 Sec. VII-C)\n\n| run | protocol frames: angle [deg] | distance "
          "[cm] | planes | all frames: angle [deg] | distance [cm] | planes "
          "|\n|---|---|---|---|---|---|---|\n";
    for (const Run& r : runs) {
      const RunSummary s = summarize(r);
      md << "| " << r.label << " | " << fmtPm(s.planes_protocol.angle, 1.0, 2) << " | "
         << fmtPm(s.planes_protocol.distance, 100.0, 2) << " | " << s.planes_protocol.angle.n
         << " | " << fmtPm(s.planes_all.angle, 1.0, 2) << " | "
         << fmtPm(s.planes_all.distance, 100.0, 2) << " | " << s.planes_all.angle.n << " |\n";
    }
    md << "\nProtocol: all safe planes of " << opt.plane_frames
       << " frames per dataset drawn at random (seed " << opt.seed
       << "), averaged over all planes of all datasets (paper: 1.2 +- 0.5 deg, 1.9 +- "
          "0.8 cm).\n\n";
  }
  // Latency.
  bool any_latency = false;
  for (const Run& r : runs)
    for (const DatasetResult& d : r.datasets)
      any_latency = any_latency || !d.latency.empty();
  if (any_latency) {
    md << "## Frame latency (000 Sec. VII-B)\n\nCamera frames from the board's appearance until "
          "50 % / 90 % of its width is occupied in the 3D grid (-1: not reached before the "
          "sequence ends; the robot stops 0.6 m from the board). Plot: fig6b_latency.png.\n\n"
          "| run | dataset | start distance [m] | frames to 50 % | frames to 90 % | frames seen | "
          "final coverage |\n"
          "|---|---|---|---|---|---|---|\n";
    for (const Run& r : runs)
      for (const DatasetResult& d : r.datasets)
        for (const LatencyResult& l : d.latency)
          md << "| " << r.label << " | " << d.name << " | " << fmt(l.start_distance, 2) << " | "
             << l.frames_to_50 << " | " << l.frames_to_90 << " | " << l.frames_available << " | "
             << fmt(l.coverage.empty() ? kNaN : 100 * l.coverage.back(), 0) << " % |\n";
    md << "\n";
  }
  // Timings.
  md << "## Time per stage [ms] (this machine, single thread)\n\n| run | ";
  for (const char* n : kStageNames)
    md << n << " | ";
  md << "real-time factor |\n|---|";
  for (int k = 0; k <= kStages; ++k)
    md << "---|";
  md << "\n";
  for (const Run& r : runs) {
    RunSummary s = summarize(r);
    if (s.datasets == 0) {  // latency-only runs
      for (const DatasetResult& d : r.datasets)
        for (int k = 0; k < kStages; ++k)
          s.stage_ms[k].v.insert(s.stage_ms[k].v.end(), d.stage_ms[k].v.begin(),
                                 d.stage_ms[k].v.end());
    }
    md << "| " << r.label << " (mean / median) | ";
    for (int k = 0; k < kStages; ++k)
      md << fmt(s.stage_ms[k].mean(), 1) << " / " << fmt(s.stage_ms[k].quantile(0.5), 1) << " | ";
    md << (s.wall_seconds > 0 ? fmt(s.bag_seconds / s.wall_seconds, 2) : std::string("n/a"))
       << " |\n";
  }
  md << "\nStages: disparity = matching and post-filters (shared by all decr values: the first "
        "run's time), update = voxel grid (000: 92 ms), segmentation = Alg. 1 (000: 4 ms), "
        "plane_fit (000: 61 ms), labelling = Alg. 2 (000: 71 ms). The real-time factor is bag "
        "duration over wall time for all runs of a dataset together.\n\n";
  // Images.
  md << "## Images\n\n";
  if (fileExists(opt.out + "/model_3d.png")) md << "![3D model](model_3d.png)\n\n";
  for (const Run& r : runs)
    for (const DatasetResult& d : r.datasets)
      for (const std::string& im : d.images)
        md << "![" << d.name << "](" << im << ")\n";
  md << "\n";
  // Problems.
  bool any_problem = false;
  for (const Run& r : runs)
    for (const DatasetResult& d : r.datasets)
      any_problem = any_problem || !d.problems.empty();
  if (any_problem) {
    md << "## Problems\n\n";
    for (const Run& r : runs)
      for (const DatasetResult& d : r.datasets)
        for (const auto& p : d.problems)
          md << "- " << r.label << " " << d.name << ": " << p.second << " x " << p.first << "\n";
  }
  std::ofstream f(opt.out + "/report.md");
  if (!f) return "cannot write " + opt.out + "/report.md";
  f << md.str();
  return "";
}

}  // namespace evaluate_safety_map
