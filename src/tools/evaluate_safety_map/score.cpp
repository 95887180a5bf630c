// evaluate_safety_map: scores. One map against the GT (confusion of 000 Sec. VII-A, where the
// FPs are, plane accuracy of 000 Sec. VII-C), a run's summary over datasets, the targets.
#include "evaluate_safety_map.h"

#include <cmath>

namespace evaluate_safety_map {

void evaluateFrameMap(const ssm::Dataset& ds, const ssm::SafetyMap& map, int frame, double stamp,
                      bool protocol_frame, FrameRecord* rec, DatasetResult* res,
                      std::vector<ssm::CellOutcome>* outcomes) {
  rec->robot_segment = map.robot_segment >= 0;
  const std::string e = ssm::countConfusion(map, ds.gt, &rec->counts, outcomes);
  if (!e.empty()) {
    ++res->problems["confusion: " + e];
    return;
  }
  res->sum += rec->counts;
  if (rec->robot_segment) {
    res->seeded += rec->counts;
    if (outcomes != nullptr && map.segment.size() == outcomes->size()) {
      for (std::size_t k = 0; k < outcomes->size(); ++k) {
        if ((*outcomes)[k] != ssm::CellOutcome::kFalsePositive) continue;
        ++(map.segment[k] >= 0 ? res->fp_in_segment : res->fp_no_segment);
      }
    }
  } else {
    ++res->without_robot_segment;
    res->fp_without_robot_segment += rec->counts.fp;
  }
  (void)stamp;
  for (const ssm::SegmentInfo& s : map.segments) {
    if (!ssm::isSafe(s.label) || !s.plane.valid) continue;
    const ssm::PlaneAccuracy a = ssm::comparePlane(s.plane, s.cells, map, ds.planes);
    if (!a.matched) continue;
    PlaneSample p;
    p.frame = frame;
    p.reference = ds.planes[a.reference].name;
    p.angle_deg = a.angle_deg;
    p.distance = a.mean_distance;
    p.cells = a.cells;
    p.label = s.label;
    res->planes_all.push_back(p);
    if (protocol_frame) res->planes_protocol.push_back(p);
  }
}

PlaneSummary summarize(const std::vector<PlaneSample>& v) {
  std::vector<double> a, d;
  for (const auto& p : v) {
    a.push_back(p.angle_deg);
    d.push_back(p.distance);
  }
  return {ssm::meanStd(a), ssm::meanStd(d)};
}

RunSummary summarize(const Run& run) {
  RunSummary s;
  std::vector<double> fn, fp, tp, tn, p, r, f1, sfn, sfp, lfn, lfp;
  std::vector<PlaneSample> pp, pa;
  for (const DatasetResult& d : run.datasets) {
    if (d.latency_only) continue;
    ++s.datasets;
    s.maps += d.integrated;
    s.without_robot_segment += d.without_robot_segment;
    const ssm::ErrorRates e = ssm::errorRates(d.sum);
    const ssm::SafeClassScores c = ssm::safeClassScores(d.sum);
    const ssm::ErrorRates es = ssm::errorRates(d.seeded);
    fn.push_back(e.fn);
    fp.push_back(e.fp);
    tp.push_back(e.tp);
    tn.push_back(e.tn);
    p.push_back(c.precision);
    r.push_back(c.recall);
    f1.push_back(c.f1);
    sfn.push_back(es.fn);
    sfp.push_back(es.fp);
    if (d.local_maps > 0) {
      const ssm::ErrorRates el = ssm::errorRates(d.local);
      lfn.push_back(el.fn);
      lfp.push_back(el.fp);
    }
    pp.insert(pp.end(), d.planes_protocol.begin(), d.planes_protocol.end());
    pa.insert(pa.end(), d.planes_all.begin(), d.planes_all.end());
    for (int k = 0; k < kStages; ++k)
      s.stage_ms[k].v.insert(s.stage_ms[k].v.end(), d.stage_ms[k].v.begin(), d.stage_ms[k].v.end());
    s.bag_seconds += d.bag_seconds;
    s.wall_seconds += d.wall_seconds;
  }
  s.fn = ssm::meanStd(fn);
  s.fp = ssm::meanStd(fp);
  s.tp = ssm::meanStd(tp);
  s.tn = ssm::meanStd(tn);
  s.precision = ssm::meanStd(p);
  s.recall = ssm::meanStd(r);
  s.f1 = ssm::meanStd(f1);
  s.seeded_fn = ssm::meanStd(sfn);
  s.seeded_fp = ssm::meanStd(sfp);
  s.local_fn = ssm::meanStd(lfn);
  s.local_fp = ssm::meanStd(lfp);
  s.planes_protocol = summarize(pp);
  s.planes_all = summarize(pa);
  return s;
}

// The targets at the default parameters (decr = 1).
std::vector<Target> targets(const std::vector<Run>& runs) {
  std::vector<Target> t;
  const Run* r1 = nullptr;
  for (const Run& r : runs)
    if (r.decr == 1 || (r.decr < 0 && r1 == nullptr)) r1 = &r;
  if (r1 == nullptr) return t;
  const RunSummary s = summarize(*r1);
  if (s.datasets > 0) {
    t.push_back({"FN rate (mean over datasets)", 100 * s.fn.mean, 1.5, "%", "3.0 +- 1.8 %"});
    t.push_back({"FP rate (mean over datasets)", 100 * s.fp.mean, 5.0, "%", "9.3 +- 4.7 %"});
    t.push_back({"plane normal error (paper protocol)", s.planes_protocol.angle.mean, 0.6, "deg",
                 "1.2 +- 0.5 deg"});
    t.push_back({"plane distance (paper protocol)", 100 * s.planes_protocol.distance.mean, 1.0,
                 "cm", "1.9 +- 0.8 cm"});
  }
  // 50 % of the textured board at 5 m.
  double best = kNaN;
  for (const DatasetResult& d : r1->datasets) {
    if (!d.latency_only || d.name.find("untextured") != std::string::npos) continue;
    for (const LatencyResult& l : d.latency) {
      if (std::isfinite(l.start_distance) && std::abs(l.start_distance - 5.0) < 0.3)
        best = l.frames_to_50 > 0 ? l.frames_to_50 : std::numeric_limits<double>::infinity();
    }
  }
  if (!std::isnan(best))
    t.push_back({"frames to 50 % of the textured board at 5 m", best, 5.0, "frames", "8 frames"});
  return t;
}

}  // namespace evaluate_safety_map
