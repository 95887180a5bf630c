// evaluate_hybrid: output. metrics.json (tools/json.h) and report.md.
#include "evaluate_hybrid.h"

#include "stereo_safety_map/tools/json.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace evaluate_hybrid {

// ---------------------------------------------------------------------------------------------
// Output

std::string fmt(double v, int digits = 2) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}
std::string pct(double v, int digits = 1) {
  return std::isfinite(v) ? fmt(100.0 * v, digits) + " %" : "n/a";
}
double ratio(std::uint64_t a, std::uint64_t b) {
  return b > 0 ? static_cast<double>(a) / b : kNaN;
}

using stereo_safety_map::tools::Json;  // tools/json.h

// 001's A, B, C: safe in both, safe in the map only, safe in the ground truth only.
void jsonCounts(Json& j, const std::string& k, const ConfusionCounts& c) {
  const ssm::SafeClassScores s = ssm::safeClassScores(c);
  j.key(k).open('{').kv("A", c.tn).kv("B", c.fn).kv("C", c.fp).kv("unsafe_both", c.tp);
  j.kv("precision", s.precision).kv("recall", s.recall).kv("f1", s.f1).close('}');
}

void writeOutputs(const Options& opt, const std::string& command, double wall_s,
                  const std::vector<FusionResult>& fusion,
                  const std::vector<LandmarkResult>& landmarks) {
  // Table 2 over the --bag datasets (the overhang scenes are reported on their own).
  ConfusionCounts total_own[kSources], total_common[kSources];
  for (std::size_t k = 0; k < opt.bags.size(); ++k) {
    for (int s = 0; s < kSources; ++s) {
      total_own[s] += fusion[k].own[s];
      total_common[s] += fusion[k].common[s];
    }
  }

  // ---- JSON (its layout: one line per top-level member and per dataset)
  Json j;
  j.open('{').wrap(2).kv("command", command).wrap(2).kv("wall_s", wall_s);
  // 001 Table 2's precision / recall / F1, as the paper prints them.
  const char* const paper_table2[3][3] = {
      {"0.78", "0.99", "0.87"}, {"0.94", "0.86", "0.90"}, {"0.94", "0.89", "0.92"}};
  j.wrap(2).key("paper_table2").open('{');
  for (int s = 0; s < 3; ++s) {
    j.key(kSourceNames[s]).open('[');
    for (const char* v : paper_table2[s])
      j.raw(v);
    j.close(']');
  }
  j.close('}');
  j.wrap(2).key("table2").open('{');
  for (int s = 0; s < kSources; ++s) {
    j.key(kSourceNames[s]).open('{');
    jsonCounts(j, "own", total_own[s]);
    jsonCounts(j, "common", total_common[s]);
    j.close('}');
  }
  j.close('}');
  j.wrap(2).key("datasets").open('[');
  for (std::size_t k = 0; k < fusion.size(); ++k) {
    const FusionResult& r = fusion[k];
    j.wrap(4).open('{').kv("name", r.name).kv("in_table2", k < opt.bags.size());
    j.kv("pairs", r.pairs).kv("integrated", r.integrated).kv("scans", r.scans);
    j.kv("laser_z", r.laser_z);
    for (int s = 0; s < kSources; ++s) {
      j.key(kSourceNames[s]).open('{');
      jsonCounts(j, "own", r.own[s]);
      jsonCounts(j, "common", r.common[s]);
      for (int k = 0; k < kBlindKinds; ++k) {
        const CellClassCounts& c = r.blind_counts[k];
        const std::string key = kBlindKeys[k];
        j.kv(key + "_traversable", c.fraction(s, {HybridLabel::kSafe, HybridLabel::kCaution}));
        j.kv(key + "_hazard", c.fraction(s, {HybridLabel::kHazard}));
        j.kv(key + "_classified", c.classified(s));
      }
      j.close('}');
    }
    j.kv("laser_ms_median", statsOf(r.laser_ms).median);
    j.kv("build_ms_median", statsOf(r.build_ms).median).close('}');
  }
  j.wrap(2).close(']');
  j.wrap(2).key("landmark_filter").open('[');
  for (const LandmarkResult& r : landmarks) {
    j.wrap(4).open('{').kv("name", r.name).kv("disparity", r.disparity);
    j.kv("has_depth", r.has_depth).kv("ghost_px", opt.ghost_px);
    for (int on = 0; on < 2; ++on) {
      const LandmarkRun& run = on ? r.on : r.off;
      const ssm::ErrorRates er = ssm::errorRates(run.map);
      const ssm::SafeClassScores sc = ssm::safeClassScores(run.map);
      j.key(on ? "on" : "off").open('{').kv("integrated", run.integrated);
      j.kv("fp_rate", er.fp).kv("fn_rate", er.fn);
      j.kv("precision", sc.precision).kv("recall", sc.recall).kv("f1", sc.f1);
      j.kv("points_reprojected", run.points_reprojected).kv("points_to_grid", run.points_to_grid);
      j.kv("ghost_fraction_to_grid", ratio(run.ghosts_to_grid, run.checked_to_grid));
      j.kv("ghosts_to_grid", run.ghosts_to_grid);
      j.kv("landmark_ms_median", statsOf(run.landmark_ms).median);
      j.kv("landmark_ms_mean", statsOf(run.landmark_ms).mean);
      j.kv("landmark_ms_max", statsOf(run.landmark_ms).max);
      j.kv("landmark_cpu_ms_median", statsOf(run.landmark_cpu_ms).median);
      j.kv("landmark_cpu_ms_max", statsOf(run.landmark_cpu_ms).max);
      j.kv("frame_ms_median", statsOf(run.frame_ms).median).close('}');
    }
    j.close('}');
  }
  j.wrap(2).close(']').wrap(0).close('}');
  {
    std::ofstream out(opt.out + "/metrics.json");
    out << j.str() << "\n";
  }

  // ---- Markdown
  std::ostringstream md;
  md << "# Laser + stereo hybrid safety map (paper 001)\n\n"
     << "Command: `" << command << "` (" << fmt(wall_s, 0) << " s).\n\n";
  if (!opt.bags.empty()) {
    md << "## Table 2 of 001: safe-class precision / recall / F1\n\n"
       << "Cells of every integrated frame's map against the ground truth, summed over the "
       << opt.bags.size()
       << " datasets (A = safe in map and ground truth, B = safe in the map only, C = safe in the "
          "ground truth only; Unknown cells do not count). *Own*: each map on the cells it "
          "classifies (001's protocol); *common*: the cells all of them classify. "
          "merged_laser_fills_unknown: the merged map with laser_free_vision_unknown_is_safe "
          "(laser-free cells vision has not examined are Safe).\n\n"
       << "| map | precision | recall | F1 | precision (common) | recall (common) | F1 (common) "
          "| 001 Table 2 (P / R / F1) |\n|---|---|---|---|---|---|---|---|\n";
    const char* paper[kSources] = {"0.78 / 0.99 / 0.87", "0.94 / 0.86 / 0.90", "0.94 / 0.89 / 0.92",
                                   "-"};
    for (int s = 0; s < kSources; ++s) {
      const ssm::SafeClassScores a = ssm::safeClassScores(total_own[s]);
      const ssm::SafeClassScores b = ssm::safeClassScores(total_common[s]);
      md << "| " << kSourceNames[s] << " | " << fmt(a.precision) << " | " << fmt(a.recall) << " | "
         << fmt(a.f1) << " | " << fmt(b.precision) << " | " << fmt(b.recall) << " | " << fmt(b.f1)
         << " | " << paper[s] << " |\n";
    }
    md << "\nPer dataset (own coverage, P / R / F1):\n\n| dataset | frames | laser | stereo | "
          "merged | merged, laser fills unknown |\n|---|---|---|---|---|---|\n";
    for (std::size_t k = 0; k < fusion.size(); ++k) {
      const FusionResult& r = fusion[k];
      md << "| " << r.name << (k < opt.bags.size() ? "" : " (not in the total)") << " | "
         << r.integrated;
      for (int s = 0; s < kSources; ++s) {
        const ssm::SafeClassScores a = ssm::safeClassScores(r.own[s]);
        md << " | " << fmt(a.precision) << " / " << fmt(a.recall) << " / " << fmt(a.f1);
      }
      md << " |\n";
    }
  }
  if (!fusion.empty()) {
    md << "\n## What the laser cannot see\n\n"
       << "Ground-truth Non-ground cells the laser cannot see: under obstacles whose bottom "
          "lies between the laser plane and the robot's height (overhangs: table tops, shelves), "
          "in obstacles entirely below the plane, and Non-ground ground with no obstacle within "
          "0.1 m (below drop-offs, too steep, unreachable); cells within 0.1 m of an obstacle "
          "that reaches into the plane are left out. Over all integrated frames: the share of "
          "the cell observations each map classifies (not Unknown) that it calls traversable "
          "(Safe / Caution) or Hazard, and how many it classifies.\n\n"
       << "| dataset | kind (obstacles) | GT cells | laser: traversable | stereo: traversable | "
          "merged: traversable | merged: hazard | observations classified (laser / stereo / "
          "merged) |\n|---|---|---|---|---|---|---|---|\n";
    for (const FusionResult& r : fusion) {
      for (int kind = 0; kind < kBlindKinds; ++kind) {
        const CellClassCounts& c = r.blind_counts[kind];
        if (r.blind.cells[kind].empty()) continue;
        std::string list;
        for (const std::string& n : r.blind.names[kind])
          list += (list.empty() ? "" : ", ") + n;
        md << "| " << r.name << " | " << kBlindNames[kind]
           << (list.empty() ? "" : " (" + list + ")") << " | " << r.blind.cells[kind].size()
           << " | " << pct(c.fraction(0, {HybridLabel::kSafe, HybridLabel::kCaution})) << " | "
           << pct(c.fraction(1, {HybridLabel::kSafe, HybridLabel::kCaution})) << " | "
           << pct(c.fraction(2, {HybridLabel::kSafe, HybridLabel::kCaution})) << " | "
           << pct(c.fraction(2, {HybridLabel::kHazard})) << " | " << c.classified(0) << " / "
           << c.classified(1) << " / " << c.classified(2) << " |\n";
      }
    }
    for (const FusionResult& r : fusion) {
      for (const std::string& img : r.images) {
        md << "\n![" << r.name << "](" << img << ")\n\n"
           << "Last frame of " << r.name
           << ": laser only, stereo only, merged, ground truth (obstacles black, hazards dark "
              "grey, caution yellow, unknown light grey, safe white; in the ground truth the "
              "cells the laser cannot see are drawn as hazards).\n";
      }
    }
    md << "\nTime per frame (median): laser scan ray casting " <<
        [&] {
          std::vector<double> all;
          for (const FusionResult& r : fusion)
            all.insert(all.end(), r.laser_ms.begin(), r.laser_ms.end());
          return fmt(statsOf(all).median, 3);
        }()
       << " ms, building one hybrid map " <<
        [&] {
          std::vector<double> all;
          for (const FusionResult& r : fusion)
            all.insert(all.end(), r.build_ms.begin(), r.build_ms.end());
          return fmt(statsOf(all).median, 3);
        }()
       << " ms.\n";
  }
  if (!landmarks.empty()) {
    md << "\n## Landmark filter (001 Sec. 4.2) in front of the voxel grid\n\n"
       << "The same disparity images mapped without and with the filter. Map rates as 000 Sec. "
          "VII-A (unsafe positive: FP = unsafe in the map, safe in the ground truth), summed over "
          "the integrated frames; ghost points: points reaching the voxel grid whose disparity is "
          "more than "
       << fmt(opt.ghost_px, 1)
       << " px from the ground-truth depth's; time: the filter's update per frame, wall and "
          "thread CPU (the machine may be shared; bench_landmark_filter measures the filter "
          "alone). Disparity: the post-filters as configured, or the matcher alone (its "
          "uniqueness test only), closer to the raw dense stereo of 001.\n\n"
       << "| dataset | disparity | filter | frames | FP rate | FN rate | safe P / R / F1 | points "
          "to the grid per frame | ghost points to the grid | of which ghosts | filter wall "
          "median / max [ms] | filter CPU median / max [ms] |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const LandmarkResult& r : landmarks) {
      for (int on = 0; on < 2; ++on) {
        const LandmarkRun& run = on ? r.on : r.off;
        const ssm::ErrorRates er = ssm::errorRates(run.map);
        const ssm::SafeClassScores sc = ssm::safeClassScores(run.map);
        const std::size_t frames = on ? run.landmark_ms.size() : run.frame_ms.size();
        md << "| " << r.name << " | " << r.disparity << " | " << (on ? "on" : "off") << " | "
           << run.integrated << " | " << pct(er.fp, 2) << " | " << pct(er.fn, 2) << " | "
           << fmt(sc.precision) << " / " << fmt(sc.recall) << " / " << fmt(sc.f1) << " | "
           << fmt(frames ? static_cast<double>(run.points_to_grid) / frames : kNaN, 0) << " | "
           << (r.has_depth ? std::to_string(run.ghosts_to_grid) : "n/a (no depth)") << " | "
           << (r.has_depth ? pct(ratio(run.ghosts_to_grid, run.checked_to_grid), 2) : "n/a")
           << " | "
           << (on ? fmt(statsOf(run.landmark_ms).median, 1) + " / " +
                        fmt(statsOf(run.landmark_ms).max, 1)
                  : "-")
           << " | "
           << (on ? fmt(statsOf(run.landmark_cpu_ms).median, 1) + " / " +
                        fmt(statsOf(run.landmark_cpu_ms).max, 1)
                  : "-")
           << " |\n";
      }
    }
    md << "\nPermanent landmarks at the end: ";
    for (std::size_t k = 0; k < landmarks.size(); ++k)
      md << (k ? ", " : "") << landmarks[k].name << " (" << landmarks[k].disparity << ") "
         << landmarks[k].on.permanent;
    md << ".\n";
  }
  {
    std::ofstream out(opt.out + "/report.md");
    out << md.str();
  }
  std::printf("%s", md.str().c_str());
  std::printf("wrote %s/report.md and %s/metrics.json in %.0f s\n", opt.out.c_str(),
              opt.out.c_str(), wall_s);
}

}  // namespace evaluate_hybrid
