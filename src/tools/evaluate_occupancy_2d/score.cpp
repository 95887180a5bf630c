// evaluate_occupancy_2d: scores. Recall / precision / FP rate of the occupied class, and the GT's
// Non-ground cells by cause.
#include "evaluate_occupancy_2d.h"

#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/scene_loader.h"

#include <algorithm>
#include <cmath>

namespace evaluate_occupancy_2d {

namespace ds = stereo_safety_map::dataset;

double ratio(std::uint64_t a, std::uint64_t b) {
  return b > 0 ? static_cast<double>(a) / static_cast<double>(b) : kNaN;
}
double recallOf(const ssm::ConfusionCounts& c) {
  return ratio(c.tp, c.tp + c.fn);
}
double precisionOf(const ssm::ConfusionCounts& c) {
  return ratio(c.tp, c.tp + c.fp);
}
double fpRateOf(const ssm::ConfusionCounts& c) {
  return ratio(c.fp, c.fp + c.tn);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5));
  return v[k];
}
double mean(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  double s = 0.0;
  for (double x : v)
    s += x;
  return s / v.size();
}

std::string computeCauses(const ssm::Dataset& d, const std::string& scenes_dir, GtExtras* x) {
  std::vector<ssm::UnsafeCause>* causes = &x->causes;
  ds::GroundTruthConfig gtc;  // make_dataset's
  ds::GroundTruthMap gt;
  std::string e = ds::recomputeDatasetGroundTruth(d.gt_dir, scenes_dir, gtc, &gt);
  if (!e.empty()) return "ground truth: " + e;
  const ssm::LabelGrid& lg = d.gt;
  if (gt.min_u != lg.min_u || gt.min_v != lg.min_v || gt.width != lg.width ||
      gt.height != lg.height) {
    return "recomputed ground truth differs in size from the dataset's (scene file changed?)";
  }
  std::size_t differ = 0;
  for (std::size_t k = 0; k < gt.labels.size(); ++k)
    differ += gt.labels[k] != lg.labels[k];
  if (differ > 0) {
    return "recomputed ground truth differs from the dataset's in " + std::to_string(differ) +
           " cells (scene file changed?)";
  }
  const int start = gt.index(gt.start_u, gt.start_v);
  const double start_z = gt.ground_height[start];
  causes->assign(gt.labels.size(), ssm::UnsafeCause::kNotUnsafe);
  for (std::size_t k = 0; k < gt.labels.size(); ++k) {
    if (gt.labels[k] != ssm::SafetyLabel::kNonGround) continue;
    ssm::UnsafeCause c;
    if (gt.obstacle[k]) {
      c = ssm::UnsafeCause::kObstacle;
    } else if (gt.slope_deg[k] > gtc.theta_max_deg) {
      c = ssm::UnsafeCause::kTooSteep;
    } else if (gt.ground_height[k] <= start_z - gtc.h_t) {
      c = ssm::UnsafeCause::kLowerGround;
    } else if (gt.ground_height[k] >= start_z + gtc.h_t) {
      c = ssm::UnsafeCause::kRaisedGround;
    } else {
      c = ssm::UnsafeCause::kUnreachable;
    }
    (*causes)[k] = c;
    ++x->cause_cells[static_cast<int>(c)];
  }
  x->edge.assign(gt.labels.size(), 0);
  for (int v = gt.min_v; v < gt.min_v + gt.height; ++v) {
    for (int u = gt.min_u; u < gt.min_u + gt.width; ++u) {
      const int k = gt.index(u, v);
      if (!ssm::isSafe(gt.labels[k])) continue;
      bool edge = false;
      for (int dv = -1; dv <= 1 && !edge; ++dv) {
        for (int du = -1; du <= 1 && !edge; ++du) {
          if ((du || dv) && gt.inside(u + du, v + dv)) {
            const int n = gt.index(u + du, v + dv);
            edge = gt.ground[n] >= 0 && gt.ground_height[n] <= gt.ground_height[k] - gtc.h_t;
          }
        }
      }
      x->edge[k] = edge ? 1 : 0;
      x->edge_cells += edge ? 1 : 0;
    }
  }
  return "";
}

ssm::UnsafeCauseCounts sumCauses(const std::vector<DatasetResult>& all, int variant, bool safety) {
  ssm::UnsafeCauseCounts s;
  for (const DatasetResult& d : all) {
    if (d.kind != Kind::kBenchmark || !d.causes_ok) continue;
    s += safety ? d.safety.causes : d.grid[variant].causes;
  }
  return s;
}

}  // namespace evaluate_occupancy_2d
