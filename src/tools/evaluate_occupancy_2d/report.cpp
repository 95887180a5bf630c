// evaluate_occupancy_2d: output. metrics.json (tools/json.h), report.md, and evaluate_safety_map's
// metrics.json read for its numbers beside ours.
#include "evaluate_occupancy_2d.h"

#include "stereo_safety_map/tools/json.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>

namespace evaluate_occupancy_2d {

SafetyReference loadSafetyReference(const std::string& path) {
  SafetyReference r;
  if (path.empty() || !ssm::fileExists(path)) return r;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    for (const auto& run : root["runs"]) {
      if (run["decr"].as<int>() != 1) continue;
      for (const auto& d : run["datasets"]) {
        const std::string name = d["name"].as<std::string>();
        ssm::ConfusionCounts c;
        c.tp = d["counts"]["tp"].as<std::uint64_t>();
        c.fp = d["counts"]["fp"].as<std::uint64_t>();
        c.fn = d["counts"]["fn"].as<std::uint64_t>();
        c.tn = d["counts"]["tn"].as<std::uint64_t>();
        c.maps = d["counts"]["maps"].as<std::uint64_t>();
        r.counts[name] = c;
        if (d["latency"] && d["latency"].size() > 0) {
          r.latency[name] = {d["latency"][0]["frames_to_50"].as<int>(),
                             d["latency"][0]["frames_to_90"].as<int>()};
        }
      }
      r.loaded = true;
      break;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "warning: cannot read %s: %s\n", path.c_str(), e.what());
    r.loaded = false;
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Output

std::string num(double v, int prec = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}
std::string pct(double v) {
  return std::isfinite(v) ? num(100.0 * v, 1) + " %" : "n/a";
}
std::string frames(int f) {
  return f < 0 ? "never" : std::to_string(f);
}
using stereo_safety_map::tools::Json;  // tools/json.h

void jsonCounts(Json& j, const std::string& k, const ssm::ConfusionCounts& c) {
  j.key(k).open('{').kv("tp", c.tp).kv("fp", c.fp).kv("fn", c.fn).kv("tn", c.tn);
  j.kv("recall", recallOf(c)).kv("precision", precisionOf(c)).kv("fp_rate", fpRateOf(c));
  j.close('}');
}

void jsonCauses(Json& j, const std::string& k, const ssm::UnsafeCauseCounts& c) {
  j.key(k).open('{');
  for (int i = 1; i < ssm::kNumUnsafeCauses; ++i) {
    j.key(ssm::toString(static_cast<ssm::UnsafeCause>(i))).open('{');
    j.kv("occupied", c.occupied[i]).kv("free", c.free[i]);
    j.kv("unclassified", c.unclassified[i]).close('}');
  }
  j.close('}');
}

void jsonEdges(Json& j, const std::string& k, const ssm::DropOffEdgeCounts& c) {
  j.key(k).open('{').kv("marked", c.marked).kv("safe_unmarked", c.safe_unmarked);
  j.kv("unsafe", c.unsafe).kv("unclassified", c.unclassified).close('}');
}

void jsonLatency(Json& j, const std::string& k, const std::vector<Latency>& v) {
  j.key(k).open('[');
  for (const Latency& l : v) {
    j.open('{').kv("board", l.board).kv("start_distance_m", l.start_distance);
    j.kv("appear_frame", l.appear_frame).kv("frames_to_50", l.frames_to_50);
    j.kv("frames_to_90", l.frames_to_90);
    j.kv("final_coverage", l.coverage.empty() ? kNaN : l.coverage.back()).close('}');
  }
  j.close(']');
}

void jsonMapper(Json& j, const MapperResult& m) {
  j.kv("maps", m.maps);
  jsonCounts(j, "counts", m.counts);
  jsonCauses(j, "causes", m.causes);
  jsonEdges(j, "drop_off_edges", m.edges);
  jsonLatency(j, "latency", m.latency);
}

// Its layout: one line per top-level member, per dataset's part and per grid variant.
std::string writeJson(const Options& opt, const Setup& s, const std::vector<DatasetResult>& all) {
  Json j;
  j.open('{').wrap(2).kv("tool", "evaluate_occupancy_2d").wrap(2).kv("command", opt.command);
  j.wrap(2).key("grid").open('{').kv("resolution", s.grid.resolution).kv("k", s.grid.k);
  j.kv("free_threshold", s.grid.free_threshold);
  j.kv("occupied_threshold", s.grid.occupied_threshold);
  j.kv("floor_clearance", s.grid.floor_clearance);
  j.kv("robot_height", s.grid.robot_height).close('}');
  j.wrap(2).kv("radius_m", s.radius);
  j.wrap(2).key("datasets").open('[');
  for (const DatasetResult& d : all) {
    j.wrap(4).open('{').kv("name", d.name).kv("kind", kindName(d.kind));
    j.kv("pairs", d.pairs).kv("rejected", d.rejected).kv("causes", d.causes_ok);
    j.kv("note", d.note).kv("gt_drop_off_edge_cells", d.gt_edge_cells);
    j.key("gt_non_ground_cells").open('{');
    for (int k = 1; k < ssm::kNumUnsafeCauses; ++k)
      j.kv(ssm::toString(static_cast<ssm::UnsafeCause>(k)), d.gt_cause_cells[k]);
    j.close('}');
    j.wrap(5).key("grid").open('[');
    for (int v = 0; v < kNumVariants; ++v) {
      if (v > 0) j.wrap(8);
      j.open('{').kv("variant", kVariants[v].name).kv("spike_removal", kVariants[v].spikes);
      j.kv("accuracy_preservation", kVariants[v].preservation);
      jsonMapper(j, d.grid[v]);
      j.close('}');
    }
    j.close(']');
    j.wrap(5).key("safety_map");
    if (d.safety_ran) {
      j.open('{');
      jsonMapper(j, d.safety);
      j.close('}');
    } else {
      j.null();
    }
    j.wrap(5).key("timings_ms").open('{').kv("disparity_mean", mean(d.disparity_ms));
    j.kv("grid_update_mean", mean(d.grid_ms));
    j.kv("grid_update_p90", percentile(d.grid_ms, 0.9));
    j.kv("safety_map_mean", mean(d.safety_ms)).close('}').close('}');
  }
  j.wrap(2).close(']').wrap(0).close('}');
  std::ofstream f(opt.out + "/metrics.json");
  if (!f) return "cannot write " + opt.out + "/metrics.json";
  f << j.str() << "\n";
  return "";
}

std::string writeReport(const Options& opt, const Setup& s, const std::vector<DatasetResult>& all,
                        const SafetyReference& ref, double wall_s) {
  std::ostringstream md;
  md << "# 2D stereo occupancy grid (paper 002) beside the safety map\n\n"
     << "Made by `" << opt.command << "` in " << num(wall_s, 0) << " s.\n\n"
     << "The grid of Murray & Little 1998 (`core/occupancy_grid_2d.h`): per image column the "
        "largest disparity whose point lies "
     << num(s.grid.floor_clearance, 2) << " .. " << num(s.grid.robot_height, 2)
     << " m above the floor (002 Sec. 3.3), trapezoid sensor model and clear triangle (Sec. "
        "3.2), +/-K = "
     << s.grid.k << " on 0..255, free < " << s.grid.free_threshold << ", occupied > "
     << s.grid.occupied_threshold
     << " (Sec. 3.4). Occupied counts as Non-ground (the positive class), free as Level; cells "
        "within "
     << num(s.radius, 1)
     << " m of the robot (the safety map's R_max) classified in the map and the GT, summed over "
        "all frames of a dataset (the 2D grid integrates every frame; the safety map skips "
        "stationary ones). Both mappers get the same disparity images (DisparityPipeline with the "
        "settings of `"
     << opt.core_params
     << "`, spike removal on); the safety map is run here by the nodelet's code path "
        "(StereoFrameProcessor::processDisparity), i.e. evaluate_safety_map's decr = 1.\n\n";

  // --- recall / precision ---
  md << "## Obstacle recall and precision\n\n"
     << "Recall = TP / (TP + FN) over all GT Non-ground cells; precision = TP / (TP + FP); "
        "obstacle recall counts only the GT cells where an object stands (the cells this mapper "
        "is built for).\n\n"
     << "| dataset | 2D grid recall | 2D grid obstacle recall | 2D grid precision | 2D grid FP "
        "rate | safety map recall | safety map precision | safety map FP rate | 2D maps | "
        "safety maps |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<double> gr, gor, gp, sr, sp;
  const int obstacle = static_cast<int>(ssm::UnsafeCause::kObstacle);
  for (const DatasetResult& d : all) {
    if (d.kind != Kind::kBenchmark) continue;
    const MapperResult& g = d.grid[0];
    const double obstacle_recall =
        d.causes_ok ? ratio(g.causes.occupied[obstacle],
                            g.causes.occupied[obstacle] + g.causes.free[obstacle])
                    : kNaN;
    gr.push_back(recallOf(g.counts));
    gor.push_back(obstacle_recall);
    gp.push_back(precisionOf(g.counts));
    sr.push_back(recallOf(d.safety.counts));
    sp.push_back(precisionOf(d.safety.counts));
    md << "| " << d.name << " | " << num(recallOf(g.counts)) << " | " << num(obstacle_recall)
       << " | " << num(precisionOf(g.counts)) << " | " << num(fpRateOf(g.counts)) << " | "
       << (d.safety_ran ? num(recallOf(d.safety.counts)) : "-") << " | "
       << (d.safety_ran ? num(precisionOf(d.safety.counts)) : "-") << " | "
       << (d.safety_ran ? num(fpRateOf(d.safety.counts)) : "-") << " | " << g.maps << " | "
       << (d.safety_ran ? std::to_string(d.safety.maps) : "-") << " |\n";
  }
  if (!gr.empty()) {
    auto ms = [](const std::vector<double>& v) {
      const ssm::MeanStd m = ssm::meanStd(v);
      return num(m.mean) + " +/- " + num(m.stddev);
    };
    md << "| **mean +/- std** | " << ms(gr) << " | " << ms(gor) << " | " << ms(gp) << " | | "
       << ms(sr) << " | " << ms(sp) << " | | | |\n";
  }
  if (ref.loaded) {
    md << "\nevaluate_safety_map's own decr = 1 run (`--safety-metrics " << opt.safety_metrics
       << "`), same definitions: ";
    bool first = true;
    for (const DatasetResult& d : all) {
      if (d.kind != Kind::kBenchmark) continue;
      const auto it = ref.counts.find(d.name);
      if (it == ref.counts.end()) continue;
      md << (first ? "" : "; ") << d.name << " recall " << num(recallOf(it->second))
         << ", precision " << num(precisionOf(it->second));
      first = false;
    }
    md << ".\n";
  }

  // --- causes ---
  md << "\n## What the 2D grid cannot see\n\n"
     << "GT Non-ground cell-frames of the benchmark datasets by cause (recomputed from each "
        "dataset's scene file with the dataset's ground-truth code): *occupied* / *unsafe* = "
        "seen, *free* / *safe* = the map invites the robot in, *unclassified* = unknown to the "
        "map. Lower ground is the low side of a drop-off or curb: below the 2D grid's height band, "
        "so it gives no reading and is cleared by the readings of whatever stands beyond it. A "
        "ramp too steep is seen only where it rises into the band (above floor_clearance), a "
        "steep ramp down never; raised ground only when its step exceeds floor_clearance.\n\n"
     << "| cause | GT cell-frames | 2D grid occupied | 2D grid free | 2D grid unclassified | "
        "safety map unsafe | safety map safe | safety map unclassified |\n"
     << "|---|---|---|---|---|---|---|---|\n";
  const ssm::UnsafeCauseCounts gc = sumCauses(all, 0, false);
  const ssm::UnsafeCauseCounts sc = sumCauses(all, 0, true);
  bool any_safety = false;
  for (const DatasetResult& d : all)
    any_safety = any_safety || (d.kind == Kind::kBenchmark && d.safety_ran);
  for (int k = 1; k < ssm::kNumUnsafeCauses; ++k) {
    const std::uint64_t n = gc.occupied[k] + gc.free[k] + gc.unclassified[k];
    if (n == 0) continue;
    const std::uint64_t ns = sc.occupied[k] + sc.free[k] + sc.unclassified[k];
    md << "| " << ssm::toString(static_cast<ssm::UnsafeCause>(k)) << " | " << n << " | "
       << gc.occupied[k] << " (" << pct(ratio(gc.occupied[k], n)) << ") | " << gc.free[k] << " ("
       << pct(ratio(gc.free[k], n)) << ") | " << gc.unclassified[k] << " | ";
    if (any_safety) {
      md << sc.occupied[k] << " (" << pct(ratio(sc.occupied[k], ns)) << ") | " << sc.free[k] << " ("
         << pct(ratio(sc.free[k], ns)) << ") | " << sc.unclassified[k] << " |\n";
    } else {
      md << "- | - | - |\n";
    }
  }
  // Drop-off edges.
  ssm::DropOffEdgeCounts ge, se;
  for (const DatasetResult& d : all) {
    if (d.kind != Kind::kBenchmark || !d.causes_ok) continue;
    ge += d.grid[0].edges;
    if (d.safety_ran) se += d.safety.edges;
  }
  md << "\nGT drop-off edges (safe cells next to ground lower by >= h_T, 000 Sec. VI), "
        "cell-frames: "
        "the 2D grid cannot mark them, it can only call them free, occupied or unknown.\n\n"
     << "| mapper | edge cell-frames | marked as potential drop-off edge | safe / free, not "
        "marked | Non-ground / occupied | unclassified |\n|---|---|---|---|---|---|\n"
     << "| 2D grid | " << ge.total() << " | - | " << ge.safe_unmarked << " ("
     << pct(ratio(ge.safe_unmarked, ge.total())) << ") | " << ge.unsafe << " ("
     << pct(ratio(ge.unsafe, ge.total())) << ") | " << ge.unclassified << " |\n";
  if (any_safety) {
    md << "| safety map | " << se.total() << " | " << se.marked << " ("
       << pct(ratio(se.marked, se.total())) << ") | " << se.safe_unmarked << " ("
       << pct(ratio(se.safe_unmarked, se.total())) << ") | " << se.unsafe << " ("
       << pct(ratio(se.unsafe, se.total())) << ") | " << se.unclassified << " |\n";
  }
  md << "\nGround truth of each dataset (cells of the whole GT map) and the 2D grid's misses "
        "(free / (occupied + free) cell-frames) per cause:\n\n"
     << "| dataset | obstacle | too steep | lower ground | raised ground | unreachable | "
        "drop-off edges | 2D grid free / seen, by cause |\n|---|---|---|---|---|---|---|---|\n";
  for (const DatasetResult& d : all) {
    if (d.kind == Kind::kLatency) continue;
    if (!d.causes_ok) {
      md << "| " << d.name << " | n/a | n/a | n/a | n/a | n/a | n/a | " << d.note << " |\n";
      continue;
    }
    md << "| " << d.name;
    for (int k = 1; k < ssm::kNumUnsafeCauses; ++k)
      md << " | " << d.gt_cause_cells[k];
    md << " | " << d.gt_edge_cells << " |";
    const auto& c = d.grid[0].causes;
    for (int k = 1; k < ssm::kNumUnsafeCauses; ++k) {
      if (c.occupied[k] + c.free[k] == 0) continue;
      md << " " << ssm::toString(static_cast<ssm::UnsafeCause>(k)) << " " << c.free[k] << " / "
         << (c.occupied[k] + c.free[k]) << ";";
    }
    md << " |\n";
  }

  // --- latency ---
  bool any_latency = false;
  for (const DatasetResult& d : all)
    any_latency = any_latency || (d.kind == Kind::kLatency && !d.grid[0].latency.empty());
  if (any_latency) {
    md << "\n## Frame latency (000 Sec. VII-B)\n\n"
       << "Camera frames from the board's appearance until 50 % / 90 % of its width is occupied: "
          "in the 2D grid (an occupied cell under the width sample, one cell of slack across the "
          "board) and in the safety map's 3D grid (core boardWidthCoverage, as "
          "evaluate_safety_map). 'never' = not reached before the sequence ends.\n\n"
       << "| dataset | start distance [m] | 2D grid 50 % | 2D grid 90 % | safety map 50 % | "
          "safety map 90 % |"
       << (ref.loaded ? " evaluate_safety_map 50 % / 90 % |" : "") << "\n|---|---|---|---|---|---|"
       << (ref.loaded ? "---|" : "") << "\n";
    for (const DatasetResult& d : all) {
      if (d.kind != Kind::kLatency) continue;
      for (std::size_t b = 0; b < d.grid[0].latency.size(); ++b) {
        const Latency& g = d.grid[0].latency[b];
        md << "| " << d.name << " | " << num(g.start_distance, 2) << " | " << frames(g.frames_to_50)
           << " | " << frames(g.frames_to_90) << " | ";
        if (d.safety_ran && b < d.safety.latency.size()) {
          md << frames(d.safety.latency[b].frames_to_50) << " | "
             << frames(d.safety.latency[b].frames_to_90) << " |";
        } else {
          md << "- | - |";
        }
        if (ref.loaded) {
          const auto it = ref.latency.find(d.name);
          md << " "
             << (it == ref.latency.end()
                     ? std::string("-")
                     : frames(it->second.first) + " / " + frames(it->second.second))
             << " |";
        }
        md << "\n";
      }
    }
  }

  // --- ghost obstacles ---
  bool any_compare = false;
  for (const DatasetResult& d : all)
    any_compare = any_compare || d.kind == Kind::kCompare;
  if (any_compare) {
    md << "\n## Ghost obstacles on repeating texture: spike removal and accuracy preservation\n\n"
       << "Stereo mismatches on repeating patterns (002 Sec. 4.1, the picket-fence problem) give "
          "coherent patches of wrong disparity; in the grid they become obstacles where the GT "
          "is free (FP). Spike removal (002 Sec. 4.2) and accuracy preservation (Sec. 4.3) on and "
          "off, on identical disparity images.\n\n"
       << "| dataset | variant | FP cell-frames | FP rate | precision | recall | obstacle recall "
          "|\n|---|---|---|---|---|---|---|\n";
    for (const DatasetResult& d : all) {
      if (d.kind != Kind::kCompare) continue;
      for (int v = 0; v < kNumVariants; ++v) {
        const MapperResult& m = d.grid[v];
        const double orc = d.causes_ok
                               ? ratio(m.causes.occupied[obstacle],
                                       m.causes.occupied[obstacle] + m.causes.free[obstacle])
                               : kNaN;
        md << "| " << d.name << " | " << kVariants[v].name << " | " << m.counts.fp << " | "
           << num(fpRateOf(m.counts), 4) << " | " << num(precisionOf(m.counts)) << " | "
           << num(recallOf(m.counts)) << " | " << num(orc) << " |\n";
      }
      if (d.safety_ran) {
        md << "| " << d.name << " | safety map (spike removal on) | " << d.safety.counts.fp << " | "
           << num(fpRateOf(d.safety.counts), 4) << " | " << num(precisionOf(d.safety.counts))
           << " | " << num(recallOf(d.safety.counts)) << " | |\n";
      }
    }
  }

  // --- timings ---
  std::vector<double> dm, gm, sm;
  for (const DatasetResult& d : all) {
    dm.insert(dm.end(), d.disparity_ms.begin(), d.disparity_ms.end());
    gm.insert(gm.end(), d.grid_ms.begin(), d.grid_ms.end());
    sm.insert(sm.end(), d.safety_ms.begin(), d.safety_ms.end());
  }
  md << "\n## Time per frame (this machine, shared cores)\n\n"
     << "| stage | mean [ms] | p90 [ms] |\n|---|---|---|\n"
     << "| disparity (matching + filters) | " << num(mean(dm), 1) << " | "
     << num(percentile(dm, 0.9), 1) << " |\n"
     << "| 2D grid update (reduction + update, 002) | " << num(mean(gm), 2) << " | "
     << num(percentile(gm, 0.9), 2) << " |\n";
  if (!sm.empty()) {
    md << "| safety map (reprojection + mapper, 000) | " << num(mean(sm), 1) << " | "
       << num(percentile(sm, 0.9), 1) << " |\n";
  }

  // --- notes and images ---
  bool notes = false;
  for (const DatasetResult& d : all) {
    if (d.note.empty() && d.problems.empty()) continue;
    if (!notes) md << "\n## Notes\n\n";
    notes = true;
    md << "- " << d.name << ": " << d.note;
    for (const auto& p : d.problems)
      md << " " << p.first << " (" << p.second << " frames);";
    md << "\n";
  }
  bool any_image = false;
  for (const DatasetResult& d : all)
    any_image = any_image || !d.images.empty();
  if (any_image) {
    md << "\n## Maps\n\n2D grid as labels (occupied black, free white, unknown grey) | GT | "
          "outcomes (TP dark, FP orange, FN red, TN pale).\n\n";
    for (const DatasetResult& d : all)
      for (const std::string& im : d.images)
        md << "![" << im << "](" << im << ")\n";
  }
  std::ofstream f(opt.out + "/report.md");
  if (!f) return "cannot write " + opt.out + "/report.md";
  f << md.str();
  return "";
}

}  // namespace evaluate_occupancy_2d
