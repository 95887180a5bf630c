// evaluate_safety_map: the runs. Offline: the core (StereoFrameProcessor) on each stereo pair of
// each dataset with the pose from the bag's tf, one mapper per --decr value, the local-horizon GT,
// frame latency (000 Sec. VII-B), images. Recorded: the nodelets' SafetyMap messages.
#include "evaluate_safety_map.h"

#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/ros/msgs.h"
#include "stereo_safety_map/tools/boards.h"

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <set>

namespace evaluate_safety_map {

namespace sdata = stereo_safety_map::dataset;

// ---------------------------------------------------------------------------------------------
// Offline evaluation: the core on each stereo pair of each dataset, one mapper per decr value.

struct MapperSlot {
  std::unique_ptr<ssm::StereoFrameProcessor> processor;
  DatasetResult* result = nullptr;
};

// --dump-frame: one line per segment of a map, and what the cells of each label are in the GT.
void dumpSegments(const ssm::Dataset& ds, const ssm::SafetyMap& map, int frame) {
  std::printf("%s pair %d: %zu segments, robot segment %d, robot cell (%d, %d)\n", ds.name.c_str(),
              frame, map.segments.size(), map.robot_segment, map.robot_u, map.robot_v);
  std::printf(
      "  id label      cells int bnd   w island reach slope_deg  rms_cm points  "
      "x_mean y_mean  gt: level incl nonground unknown\n");
  for (const ssm::SegmentInfo& s : map.segments) {
    int gt[5] = {0, 0, 0, 0, 0};
    double sx = 0.0, sy = 0.0;
    for (int c : s.cells) {
      const int u = map.min_u + c % map.width, v = map.min_v + c / map.width;
      ++gt[static_cast<int>(ds.gt.at(u, v))];
      sx += u * map.resolution;
      sy += v * map.resolution;
    }
    if (ssm::isSafe(s.label) && gt[4] > 0) {
      std::printf("  segment %d: safe cells the GT calls Non-ground (x, y):", s.id);
      for (int c : s.cells) {
        const int u = map.min_u + c % map.width, v = map.min_v + c / map.width;
        if (ds.gt.at(u, v) == SafetyLabel::kNonGround)
          std::printf(" (%.1f, %.1f)", u * map.resolution, v * map.resolution);
      }
      std::printf("\n");
    }
    const double n = std::max<std::size_t>(1, s.cells.size());
    std::printf(
        "  %2d %-10s %5zu %3d %3d %3d %6s %5s %9.2f %7.2f %6zu %7.2f %6.2f      %5d %4d %9d %7d\n",
        s.id, ssm::toString(s.label), s.cells.size(), s.num_interior, s.num_boundary,
        s.indexed_height, s.island ? "yes" : "no", s.reachable ? "yes" : "no",
        s.plane.valid ? s.plane.slope_deg : kNaN, s.plane.valid ? 100 * s.plane.residual_rms : kNaN,
        s.plane.num_points, sx / n, sy / n, gt[2], gt[3], gt[4], gt[1]);
  }
}

std::vector<int> chooseFrames(int total, int count, unsigned seed) {
  std::vector<int> all(total);
  std::iota(all.begin(), all.end(), 0);
  std::mt19937 rng(seed);
  std::shuffle(all.begin(), all.end(), rng);
  all.resize(std::min(total, count));
  std::sort(all.begin(), all.end());
  return all;
}

std::string evaluateOffline(const Options& opt, const ssm::StereoFrameProcessorConfig& base,
                            const std::vector<ssm::Dataset>& datasets, std::vector<Run>* runs) {
  runs->clear();
  for (int d : opt.decr) {
    Run r;
    r.decr = d;
    r.label = "decr=" + std::to_string(d);
    runs->push_back(r);
  }
  makeDirs(opt.out + "/maps");
  makeDirs(opt.out + "/frames");
  bool model_written = !opt.model;

  for (const ssm::Dataset& ds : datasets) {
    const Clock::time_point t_start = Clock::now();
    std::vector<MapperSlot> slots(opt.decr.size());
    for (std::size_t i = 0; i < opt.decr.size(); ++i) {
      ssm::StereoFrameProcessorConfig c = base;
      c.mapper.grid.decr = opt.decr[i];
      slots[i].processor = std::make_unique<ssm::StereoFrameProcessor>(c);
      (*runs)[i].datasets.emplace_back();
      slots[i].result = &(*runs)[i].datasets.back();
      slots[i].result->name = ds.name;
      slots[i].result->latency_only = ds.latency_only;
      for (const ssm::DatasetBoard& b : ds.boards) {
        LatencyResult l;
        l.board = b.name;
        slots[i].result->latency.push_back(l);
      }
    }

    // The local-horizon GT (see DatasetResult::local): the scene's GT map, relabelled per frame.
    sdata::GroundTruthConfig gtc;
    gtc.resolution = base.mapper.grid.voxel_size;
    gtc.h_t = base.mapper.labelling.max_step_height;
    gtc.theta_max_deg = base.mapper.labelling.max_slope_deg;
    gtc.theta_t_deg = base.mapper.labelling.level_slope_deg;
    gtc.robot_height = base.mapper.height_map.robot_height;
    sdata::GroundTruthMap scene_gt, local_gt;
    ssm::LabelGrid local_labels;
    bool have_local = false;
    if (!ds.latency_only) {
      const std::string e =
          sdata::recomputeDatasetGroundTruth(ds.gt_dir, opt.scenes, gtc, &scene_gt);
      have_local = e.empty() && scene_gt.labels.size() == ds.gt.labels.size();
      if (!have_local && !opt.quiet)
        std::fprintf(stderr, "  %s: no local-horizon GT (%s)\n", ds.name.c_str(),
                     e.empty() ? "GT map differs in size" : e.c_str());
    }
    ssm::StereoBagReaderOptions ro;
    ro.camera = opt.camera;
    ro.fixed_frame = opt.fixed_frame;
    ro.base_frame = opt.base_frame;
    ro.scan_topic.clear();
    ro.max_frames = opt.max_frames;
    ssm::StereoBagReader reader;
    std::string e = reader.open(ds.bag, ro);
    if (!e.empty()) return e;
    const double bag_seconds = reader.bagSeconds();
    const int pairs_total = reader.pairCount();

    // Frames whose planes enter the paper's protocol (000 Sec. VII-C: 5 random frames) and
    // frames whose maps are drawn.
    const std::vector<int> protocol = chooseFrames(pairs_total, opt.plane_frames, opt.seed);
    std::set<int> protocol_pending(protocol.begin(), protocol.end());
    std::set<int> image_pending;
    for (int k = 1; k <= opt.images; ++k)
      image_pending.insert(k * pairs_total / (opt.images + 1));

    bool any_protocol_due = false, any_image_due = false;
    std::vector<ssm::CellOutcome> outcomes;
    ssm::StereoBagFrame frame;

    while (reader.next(&frame)) {
      const int pair_index = frame.index;
      const ros::Time stamp = frame.stamp;
      if (protocol_pending.count(pair_index)) any_protocol_due = true;
      if (image_pending.count(pair_index)) any_image_due = true;
      if (pair_index % opt.every != 0) continue;
      for (auto& s : slots)
        ++s.result->pairs;
      if (!frame.error.empty()) {
        for (auto& s : slots) {
          ++s.result->rejected;
          ++s.result->problems[frame.error];
          FrameRecord rec;
          rec.index = pair_index;
          rec.stamp = stamp.toSec();
          rec.status = "rejected";
          s.result->frames.push_back(rec);
        }
        continue;
      }
      const ssm::StereoCameraModel& cam = frame.camera;
      const Eigen::Isometry3d& T_fixed_sensor = frame.T_fixed_sensor;
      const Eigen::Vector3d& robot = frame.robot;
      const cv::Mat& left = frame.left;
      const cv::Mat& right = frame.right;
      bool local_ok = false;
      if (have_local) {
        local_gt = scene_gt;
        local_ok = sdata::relabelGroundTruth(gtc, robot.head<2>(),
                                             base.mapper.segmentation.planning_radius, &local_gt)
                       .empty();
        if (local_ok) {
          local_labels = ds.gt;
          local_labels.labels = local_gt.labels;
        }
      }

      for (std::size_t i = 0; i < slots.size(); ++i) {
        MapperSlot& s = slots[i];
        DatasetResult& res = *s.result;
        ssm::StereoFrameResult fr;
        std::string err;
        bool ok;
        if (i == 0) {
          ok = s.processor->processImages(left, right, cam, T_fixed_sensor.cast<float>(),
                                          robot.cast<float>(), stamp.toSec(), &fr, &err);
        } else {
          // Same disparity image as the first mapper: only the grid's sensor model differs.
          const cv::Mat& disp = slots[0].processor->disparity();
          if (disp.empty()) {
            ok = false;
            err = "no disparity";
          } else {
            ok = s.processor->processDisparity(disp, slots[0].processor->disparityCamera(),
                                               T_fixed_sensor.cast<float>(), robot.cast<float>(),
                                               stamp.toSec(), &fr, &err,
                                               slots[0].processor->coarseDisparity());
          }
        }
        FrameRecord rec;
        rec.index = pair_index;
        rec.stamp = stamp.toSec();
        rec.points = fr.points;
        rec.status =
            ok ? "integrated"
               : (fr.mapper.status == ssm::FrameStatus::kStationary ? "stationary" : "rejected");
        if (ok) {
          ++res.integrated;
          const ssm::SafetyMap& map = s.processor->mapper().safetyMap();
          const bool protocol_frame = any_protocol_due;
          if (local_ok) {
            ssm::ConfusionCounts lc;
            if (ssm::countConfusion(map, local_labels, &lc).empty()) {
              res.local += lc;
              ++res.local_maps;
            }
          }
          evaluateFrameMap(ds, map, pair_index, rec.stamp, protocol_frame && !ds.latency_only, &rec,
                           &res, &outcomes);
          if (protocol_frame) res.protocol_frames.push_back(pair_index);
          if (pair_index == opt.dump_frame && i == 0) dumpSegments(ds, map, pair_index);
          const double disparity_ms =
              i == 0 ? fr.timings.disparity_ms : slots[0].result->frames.back().ms[0];
          const double values[kStages] = {
              disparity_ms,
              fr.timings.reproject_ms,
              fr.timings.mapper.integrate_ms,
              fr.timings.mapper.height_map_ms,
              fr.timings.mapper.segmentation_ms,
              fr.timings.mapper.plane_fit_ms,
              fr.timings.mapper.labelling_ms,
              fr.timings.mapper.total_ms,
              i == 0 ? fr.timings.total_ms : disparity_ms + fr.timings.total_ms};
          for (int k = 0; k < kStages; ++k) {
            rec.ms[k] = values[k];
            res.stage_ms[k].add(values[k]);
          }
          if (any_image_due && opt.images > 0) {
            const std::string name = ds.name + "_" + (*runs)[i].label.substr(0, 4) +
                                     std::to_string(opt.decr[i]) + "_frame" +
                                     std::to_string(pair_index) + ".png";
            char title[96];
            std::snprintf(title, sizeof(title), "%s frame %d, decr %d", ds.name.c_str(), pair_index,
                          opt.decr[i]);
            cv::imwrite(opt.out + "/maps/" + name,
                        mapBesideGroundTruth(map, ds.gt, outcomes, robot,
                                             ssm::yawOfOpticalAxis(T_fixed_sensor), title));
            res.images.push_back("maps/" + name);
          }
        } else {
          if (fr.mapper.status == ssm::FrameStatus::kStationary) {
            ++res.stationary;
          } else {
            ++res.rejected;
            ++res.problems[err];
          }
          if (i == 0) rec.ms[0] = fr.timings.disparity_ms;
        }
        // Frame latency (000 Sec. VII-B): counted in camera frames from the board's appearance;
        // a frame the mapper skipped keeps the previous grid.
        for (std::size_t b = 0; b < ds.boards.size(); ++b) {
          LatencyResult& l = res.latency[b];
          if (l.appear_frame < 0) {
            if (!ssm::boardInView(ds.boards[b].box, T_fixed_sensor, cam)) continue;
            l.appear_frame = static_cast<int>(res.frames.size());
            l.start_distance =
                ssm::distanceToBoardFace(ds.boards[b].box, T_fixed_sensor.translation());
          }
          l.coverage.push_back(
              ssm::boardWidthCoverage(s.processor->mapper().grid(), ds.boards[b].box).fraction());
        }
        res.frames.push_back(rec);
      }
      if (slots[0].result->frames.back().status == "integrated") {
        any_protocol_due = false;
        any_image_due = false;
      }
      if (!opt.quiet && pair_index % 50 == 0) {
        const ssm::ConfusionCounts& c = slots[0].result->sum;
        const ssm::ErrorRates r = ssm::errorRates(c);
        std::fprintf(stderr, "  %s pair %d/%d: %d maps, FN %.2f %% FP %.2f %% (decr %d)\n",
                     ds.name.c_str(), pair_index, pairs_total, slots[0].result->integrated,
                     100 * r.fn, 100 * r.fp, opt.decr[0]);
      }
    }
    for (std::size_t i = 0; i < slots.size(); ++i) {
      DatasetResult& res = *slots[i].result;
      res.bag_seconds = bag_seconds;
      res.wall_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
      for (LatencyResult& l : res.latency) {
        l.frames_available = static_cast<int>(l.coverage.size());
        l.frames_to_50 = ssm::framesUntilCoverage(l.coverage, 0.5);
        l.frames_to_90 = ssm::framesUntilCoverage(l.coverage, 0.9);
      }
      const std::string csv = "frames/" + ds.name + "_decr" + std::to_string(opt.decr[i]) + ".csv";
      e = writeFrameCsv(opt.out + "/" + csv, res, (*runs)[i].label);
      if (!e.empty()) return e;
    }
    if (!model_written && !ds.latency_only) {
      // One picture of the 3D model: the last map of the first dataset with the first decr.
      const ssm::SafetyMapper& mapper = slots[0].processor->mapper();
      if (mapper.framesIntegrated() > 0) {
        const ssm::SafetyMap& map = mapper.safetyMap();
        const Eigen::Vector3d robot(map.robot_u * map.resolution, map.robot_v * map.resolution,
                                    0.0);
        double yaw = 0.0;
        try {
          const Eigen::Isometry3d T = tf2::transformToEigen(
              reader.tf().lookupTransform(opt.fixed_frame, opt.base_frame, ros::Time(0)));
          yaw = std::atan2(T.linear()(1, 0), T.linear()(0, 0));
          cv::imwrite(opt.out + "/model_3d.png", render3dModel(mapper, T.translation(), yaw));
        } catch (const tf2::TransformException&) {
          cv::imwrite(opt.out + "/model_3d.png", render3dModel(mapper, robot, yaw));
        }
        model_written = true;
      }
    }
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Recorded mode: the SafetyMap messages the nodelets published while the bag was replayed.

ssm::SafetyMap fromMessage(const stereo_safety_map::SafetyMapMsg& msg) {
  ssm::SafetyMap m;
  const double res = msg.info.resolution;
  m.resolution = res;
  m.width = static_cast<int>(msg.info.width);
  m.height = static_cast<int>(msg.info.height);
  if (res > 0.0) {
    m.min_u = static_cast<int>(std::lround(msg.info.origin.position.x / res + 0.5));
    m.min_v = static_cast<int>(std::lround(msg.info.origin.position.y / res + 0.5));
    m.robot_u = static_cast<int>(std::lround(msg.robot_position.x / res));
    m.robot_v = static_cast<int>(std::lround(msg.robot_position.y / res));
  }
  m.robot_segment = msg.robot_segment;
  m.labels.resize(msg.labels.size());
  for (std::size_t k = 0; k < msg.labels.size(); ++k)
    m.labels[k] =
        msg.labels[k] <= 4 ? static_cast<SafetyLabel>(msg.labels[k]) : SafetyLabel::kUnknown;
  m.drop_off = msg.drop_off;
  m.segment = msg.segment;
  m.segments.resize(msg.segments.size());
  for (std::size_t i = 0; i < msg.segments.size(); ++i) {
    const auto& g = msg.segments[i];
    ssm::SegmentInfo& s = m.segments[i];
    s.id = g.id;
    s.label = g.label <= 4 ? static_cast<SafetyLabel>(g.label) : SafetyLabel::kUnknown;
    s.reachable = g.reachable;
    s.indexed_height = g.indexed_height;
    s.plane.valid = g.plane_valid;
    s.plane.a = g.a;
    s.plane.b = g.b;
    s.plane.c = g.c;
    s.plane.normal = Eigen::Vector3d(g.normal.x, g.normal.y, g.normal.z);
    s.plane.slope_deg = g.slope_deg;
  }
  if (m.segment.size() == m.labels.size()) {
    for (std::size_t k = 0; k < m.segment.size(); ++k) {
      const int s = m.segment[k];
      if (s >= 0 && s < static_cast<int>(m.segments.size()))
        m.segments[s].cells.push_back(static_cast<int>(k));
    }
  }
  return m;
}

std::string evaluateRecorded(const Options& opt, const ssm::Dataset& ds, std::vector<Run>* runs) {
  runs->assign(1, Run());
  Run& run = runs->front();
  run.label = "recorded";
  run.decr = -1;
  run.datasets.emplace_back();
  DatasetResult& res = run.datasets.back();
  res.name = ds.name;
  makeDirs(opt.out + "/maps");
  makeDirs(opt.out + "/frames");

  rosbag::Bag bag;
  try {
    bag.open(opt.recorded, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    return "cannot open " + opt.recorded + ": " + e.what();
  }
  // Topics by type, so that any namespace works.
  std::vector<std::string> map_topics, timing_topics;
  {
    rosbag::View all(bag);
    for (const rosbag::ConnectionInfo* c : all.getConnections()) {
      if (c->datatype == "stereo_safety_map/SafetyMap") map_topics.push_back(c->topic);
      if (c->datatype == "stereo_safety_map/StageTimings") timing_topics.push_back(c->topic);
    }
  }
  std::sort(map_topics.begin(), map_topics.end());
  map_topics.erase(std::unique(map_topics.begin(), map_topics.end()), map_topics.end());
  if (map_topics.empty()) return opt.recorded + ": no stereo_safety_map/SafetyMap messages";
  if (map_topics.size() > 1) map_topics.resize(1);

  // Stage timings by stamp.
  std::map<ros::Time, stereo_safety_map::StageTimingsMsg> timings;
  stereo_safety_map::StageTimingsMsg last_timing;
  if (!timing_topics.empty()) {
    rosbag::View tv(bag, rosbag::TopicQuery(timing_topics));
    for (const rosbag::MessageInstance& m : tv) {
      auto t = m.instantiate<stereo_safety_map::StageTimingsMsg>();
      if (!t) continue;
      timings[t->header.stamp] = *t;
      last_timing = *t;
    }
  }
  rosbag::View mv(bag, rosbag::TopicQuery(map_topics));
  const int total = static_cast<int>(mv.size());
  const std::vector<int> protocol = chooseFrames(total, opt.plane_frames, opt.seed);
  std::set<int> protocol_set(protocol.begin(), protocol.end());
  std::set<int> image_set;
  for (int k = 1; k <= opt.images && total > 0; ++k)
    image_set.insert(k * total / (opt.images + 1));
  int index = -1;
  std::vector<ssm::CellOutcome> outcomes;
  for (const rosbag::MessageInstance& m : mv) {
    auto msg = m.instantiate<stereo_safety_map::SafetyMapMsg>();
    if (!msg) continue;
    ++index;
    ++res.pairs;
    const ssm::SafetyMap map = fromMessage(*msg);
    FrameRecord rec;
    rec.index = index;
    rec.stamp = msg->header.stamp.toSec();
    rec.status = "integrated";
    ++res.integrated;
    evaluateFrameMap(ds, map, index, rec.stamp, protocol_set.count(index) > 0, &rec, &res,
                     &outcomes);
    if (protocol_set.count(index)) res.protocol_frames.push_back(index);
    auto t = timings.find(msg->header.stamp);
    if (t != timings.end()) {
      const double values[kStages] = {kNaN,
                                      kNaN,
                                      t->second.integrate_ms,
                                      t->second.height_map_ms,
                                      t->second.segmentation_ms,
                                      t->second.plane_fit_ms,
                                      t->second.labelling_ms,
                                      t->second.total_ms,
                                      kNaN};
      for (int k = 0; k < kStages; ++k) {
        rec.ms[k] = values[k];
        if (std::isfinite(values[k])) res.stage_ms[k].add(values[k]);
      }
    }
    if (image_set.count(index)) {
      const std::string name = ds.name + "_recorded_map" + std::to_string(index) + ".png";
      char title[96];
      std::snprintf(title, sizeof(title), "%s, recorded map %d", ds.name.c_str(), index);
      cv::imwrite(opt.out + "/maps/" + name,
                  mapBesideGroundTruth(map, ds.gt, outcomes,
                                       Eigen::Vector3d(msg->robot_position.x, msg->robot_position.y,
                                                       msg->robot_position.z),
                                       kNaN, title));
      res.images.push_back("maps/" + name);
    }
    res.frames.push_back(rec);
  }
  res.stationary = static_cast<int>(last_timing.frames_skipped_stationary);
  if (last_timing.frames_dropped > 0)
    res.problems["frames dropped by the nodelet (one-slot queue)"] =
        static_cast<int>(last_timing.frames_dropped);
  if (last_timing.frames_rejected > 0)
    res.problems["frames rejected by the nodelet"] = static_cast<int>(last_timing.frames_rejected);
  res.rejected = static_cast<int>(last_timing.frames_dropped + last_timing.frames_rejected);
  const std::string e =
      writeFrameCsv(opt.out + "/frames/" + ds.name + "_recorded.csv", res, "recorded");
  return e;
}

}  // namespace evaluate_safety_map
