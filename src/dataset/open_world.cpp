#include "stereo_safety_map/dataset/open_world.h"

#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/core/obstacle_detection.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <fstream>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include <sstream>

namespace stereo_safety_map {
namespace dataset {

namespace {

// The planar part of a pose (x, y, yaw about z).
Eigen::Isometry2d planar(const Eigen::Isometry3d& T) {
  const double yaw = std::atan2(T.linear()(1, 0), T.linear()(0, 0));
  Eigen::Isometry2d P = Eigen::Isometry2d::Identity();
  P.linear() = Eigen::Rotation2Dd(yaw).toRotationMatrix();
  P.translation() = T.translation().head<2>();
  return P;
}

constexpr double kDegToRad = 0.017453292519943295;

// The small rotation from pose `used` to pose `truth` (fixed frame), split into its components
// about the camera heading's lateral axis (pitch, positive = the front dips) and its forward axis
// (roll) [deg], added to *e.
void addTiltError(const Eigen::Isometry3d& used, const Eigen::Isometry3d& truth,
                  SceneScore::TiltError* e) {
  const Eigen::AngleAxisd aa(truth.linear() * used.linear().transpose());
  const Eigen::Vector3d w = aa.angle() * aa.axis() / kDegToRad;
  const Eigen::Vector3d axis = used.linear().col(2);  // the optical axis
  const Eigen::Vector2d fwd = Eigen::Vector2d(axis.x(), axis.y()).normalized();
  const double roll = fwd.x() * w.x() + fwd.y() * w.y();
  const double pitch = -fwd.y() * w.x() + fwd.x() * w.y();
  e->pitch += pitch;
  e->roll += roll;
  e->pitch2 += pitch * pitch;
  e->roll2 += roll * roll;
}

std::string describe(const ProceduralScene& s) {
  std::ostringstream os;
  os << s.floor_kind << (s.indoor ? " indoor" : " outdoor") << ":";
  for (const HazardItem& h : s.hazards)
    os << " " << h.kind;
  return os.str();
}

/// Development picture of a disparity against the rendered depth of the same left image:
/// PREFIX_disparity.txt (per band of 40 image rows: valid readings with a true depth, pixels
/// with one, readings more than 1 and 3 px off, median |error|) and PREFIX_disparity_error.png
/// (green within 0.5 px, yellow within 1 px, red too large = too near, blue too small).
void writeDisparityError(const cv::Mat& d, const StereoCameraModel& cam, const cv::Mat& depth,
                         const std::string& prefix) {
  if (d.empty() || d.size() != depth.size() || d.type() != CV_32FC1) return;
  std::ofstream dt(prefix + "_disparity.txt");
  dt << "# rows valid truth_finite err>1px err>3px median|err| (bands of 40 rows)\n";
  cv::Mat err_img(d.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  std::vector<float> errs;
  for (int y0 = 0; y0 < d.rows; y0 += 40) {
    int valid = 0, finite = 0, e1 = 0, e3 = 0;
    errs.clear();
    for (int y = y0; y < std::min(d.rows, y0 + 40); ++y) {
      for (int x = 0; x < d.cols; ++x) {
        const float z = depth.at<float>(y, x);
        const bool has_truth = std::isfinite(z) && z > 0.0f;
        finite += has_truth;
        const float v = d.at<float>(y, x);
        if (!(v > 0.0f) || !has_truth) continue;
        ++valid;
        const float e = v - static_cast<float>(cam.disparityFromDepth(z));
        errs.push_back(std::fabs(e));
        e1 += std::fabs(e) > 1.0f;
        e3 += std::fabs(e) > 3.0f;
        err_img.at<cv::Vec3b>(y, x) = std::fabs(e) <= 0.5f   ? cv::Vec3b(0, 160, 0)
                                      : std::fabs(e) <= 1.0f ? cv::Vec3b(0, 255, 255)
                                      : e > 0.0f             ? cv::Vec3b(0, 0, 255)
                                                             : cv::Vec3b(255, 0, 0);
      }
    }
    float med = 0.0f;
    if (!errs.empty()) {
      std::nth_element(errs.begin(), errs.begin() + errs.size() / 2, errs.end());
      med = errs[errs.size() / 2];
    }
    dt << y0 << "-" << std::min(d.rows, y0 + 40) << " " << valid << " " << finite << " " << e1
       << " " << e3 << " " << med << "\n";
  }
  cv::imwrite(prefix + "_disparity_error.png", err_img);
}

// OpenWorldRunOptions::trace_cells: one line per traced cell of this frame's map (development:
// why a cell is what it is, frame by frame).
void writeCellTrace(const SafetyMapper& mapper, const std::vector<Eigen::Vector2d>& cells,
                    const Eigen::Isometry2d& T_world_odom, const Eigen::Vector3f& base,
                    std::size_t frame, double t, const std::string& variant, std::ofstream* out) {
  const SafetyMap& m = mapper.safetyMap();
  const VoxelGrid& g = mapper.grid();
  const HeightMap& hm = mapper.heightMap();
  if (m.width <= 0) return;
  const std::int32_t robot_w = g.indexOf(base).w;
  for (const Eigen::Vector2d& cw : cells) {
    const Eigen::Vector2d co = T_world_odom.inverse() * cw;
    const int u = static_cast<int>(std::lround(co.x() / m.resolution));
    const int v = static_cast<int>(std::lround(co.y() / m.resolution));
    *out << frame << " " << t << " " << variant << " " << cw.x() << " " << cw.y() << " ";
    if (!m.inside(u, v)) {
      *out << "outside\n";
      continue;
    }
    const int c = m.index(u, v);
    const int k = m.segment[c];
    *out << toString(m.labels[c]) << " " << k;
    if (k >= 0 && k < static_cast<int>(m.segments.size())) {
      const SegmentInfo& si = m.segments[k];
      *out << "(" << toString(si.label) << " " << si.reachable << " " << si.obstacle << ")";
    }
    const int hu = u - hm.minU(), hv = v - hm.minV();
    const bool in_hm = hu >= 0 && hv >= 0 && hu < hm.width() && hv < hm.height();
    const int hc = hv * hm.width() + hu;
    *out << " " << (in_hm ? hm.atIndex(hc) : HeightMap::kNoHeight) << " "
         << (in_hm ? hm.lowestAtIndex(hc) : HeightMap::kNoHeight) << " ";
    int lo = 0, hi = 0;
    if (mapper.rememberedObstacle(u, v, &lo, &hi)) {
      *out << lo << ".." << hi;
    } else {
      *out << "-";
    }
    *out << " |";
    for (std::int32_t w = robot_w - 2; w <= hm.topIndex(); ++w) {
      const VoxelIndex vi{u, v, w};
      if (!g.contains(vi)) continue;
      *out << " " << g.logOdds(vi) << ":" << g.points(vi).size;
    }
    *out << "\n";
  }
}

}  // namespace

SafetyMap mapInWorld(const SafetyMap& map, const Eigen::Isometry2d& T_world_odom,
                     const GroundTruthMap& gt) {
  SafetyMap out;
  out.resolution = gt.resolution;
  Eigen::AlignedBox2d box;
  const double l = map.resolution;
  for (const Eigen::Vector2d& c :
       {Eigen::Vector2d(map.min_u, map.min_v), Eigen::Vector2d(map.min_u + map.width, map.min_v),
        Eigen::Vector2d(map.min_u, map.min_v + map.height),
        Eigen::Vector2d(map.min_u + map.width, map.min_v + map.height)}) {
    box.extend(T_world_odom * (l * c));
  }
  out.min_u = gt.cellOf(box.min().x());
  out.min_v = gt.cellOf(box.min().y());
  out.width = std::max(0, gt.cellOf(box.max().x()) - out.min_u + 1);
  out.height = std::max(0, gt.cellOf(box.max().y()) - out.min_v + 1);
  const std::size_t n = static_cast<std::size_t>(out.width) * out.height;
  out.labels.assign(n, SafetyLabel::kUnexamined);
  out.segment.assign(n, -1);
  out.drop_off.assign(n, 0);
  out.column_height.assign(n, SafetyMap::kNoHeight);
  const Eigen::Isometry2d T_odom_world = T_world_odom.inverse();
  for (int v = out.min_v; v < out.min_v + out.height; ++v) {
    for (int u = out.min_u; u < out.min_u + out.width; ++u) {
      const Eigen::Vector2d q =
          T_odom_world * Eigen::Vector2d(u * gt.resolution, v * gt.resolution);
      const int mu = static_cast<int>(std::lround(q.x() / l));
      const int mv = static_cast<int>(std::lround(q.y() / l));
      if (!map.inside(mu, mv)) continue;
      out.labels[out.index(u, v)] = map.labelAt(mu, mv);
      out.drop_off[out.index(u, v)] = map.drop_off[map.index(mu, mv)];
    }
  }
  const Eigen::Vector2d robot = T_world_odom * Eigen::Vector2d(map.robot_u * l, map.robot_v * l);
  out.robot_u = gt.cellOf(robot.x());
  out.robot_v = gt.cellOf(robot.y());
  out.robot_segment = map.robot_segment;
  return out;
}

OpenWorldSceneResult runOpenWorldScene(const ProceduralScene& scene,
                                       const DegradationConfig& degradation,
                                       const std::vector<OpenWorldVariant>& variants,
                                       const OpenWorldRunOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  OpenWorldSceneResult result;
  result.seed = scene.seed;
  result.description = describe(scene);
  try {
    if (variants.empty()) throw std::invalid_argument("no variant");
    // The ground truth of the undegraded geometry, from the trajectory's start.
    const SceneFile& file = scene.file;
    GroundTruthMap gt;
    std::string err =
        computeGroundTruth(file.scene, options.ground_truth,
                           Eigen::Vector2d(file.trajectory.start_x, file.trajectory.start_y), &gt);
    if (!err.empty()) throw std::runtime_error("ground truth: " + err);
    const std::vector<HazardClass> classes = hazardClassMap(scene, gt, options.ground_truth);

    // The render side of the degradation: noise, gain mismatch, grain.
    Scene rendered_scene = file.scene;
    StereoHeadConfig head = file.camera;
    head.threads = options.render_threads;
    applyToRender(degradation, &head, &rendered_scene);
    StereoRenderer renderer(rendered_scene, head, file.seed);
    const StereoCameraModel camera = stereoCameraModel(head);
    OdometryErrorModel odometry(degradation, file.seed);
    ImageDegrader degrader(degradation, file.seed);

    std::vector<std::unique_ptr<StereoFrameProcessor>> processors;
    std::vector<std::unique_ptr<ObstacleDetector>> detectors;
    for (const OpenWorldVariant& v : variants) {
      processors.push_back(std::make_unique<StereoFrameProcessor>(v.config));
      detectors.push_back(v.config.obstacle_cue || v.score_detector
                              ? std::make_unique<ObstacleDetector>(v.detector)
                              : nullptr);
    }
    cv::Mat xyz, xyz_detect;
    ObstacleDetectionResult detection;
    std::vector<Eigen::Vector3f> cue_points;
    OpenWorldScorer scorer(file.scene, gt, classes, options.scoring,
                           static_cast<int>(variants.size()));
    result.scores.assign(variants.size(), SceneScore());

    const std::vector<RobotPose> poses = sampleTrajectory(file.trajectory);
    if (poses.empty()) throw std::runtime_error("empty trajectory");
    const std::size_t frames =
        options.max_frames >= 0
            ? std::min(poses.size(), static_cast<std::size_t>(options.max_frames))
            : poses.size();
    cv::Mat left, right, depth, ids;
    GroundTruthMap local;
    std::ofstream trace;
    if (!options.trace_cells.empty() && !options.image_dir.empty()) {
      trace.open(options.image_dir + "/seed" + std::to_string(scene.seed) + "_trace.txt");
      trace << "# frame t variant x y label segment(label reachable obstacle) w lowest "
               "memory(lo..hi) | log-odds:points of the column's voxels from the robot's w - 2\n";
    }
    for (std::size_t i = 0; i < frames; ++i) {
      const RobotPose& truth = poses[i];
      const OdometryErrorModel::FramePoses fp = odometry.next(truth, head);
      if (!renderer.render(fp.true_left_optical, i, &left, &right, &depth, &ids)) {
        throw std::runtime_error("render failed at frame " + std::to_string(i));
      }
      degrader.apply(i, truth, head, &left, &right);
      const Eigen::Vector2d robot(truth.x, truth.y);
      scorer.observeFrame(fp.true_left_optical, camera, depth, ids, robot);
      // The local-horizon ground truth of this frame (reachability within R_max).
      local = gt;
      if (relabelGroundTruth(options.ground_truth, robot, options.scoring.planning_radius, &local)
              .empty()) {
        scorer.setLocalGroundTruth(&local);
      } else {
        scorer.setLocalGroundTruth(nullptr);
      }
      const Eigen::Isometry2d T_world_odom =
          planar(fp.true_base) * planar(fp.reported_base).inverse();
      const Eigen::Isometry3f T_fixed_sensor = fp.reported_left_optical.cast<float>();
      const Eigen::Vector3f base = fp.reported_base.translation().cast<float>();
      for (std::size_t k = 0; k < variants.size(); ++k) {
        StereoFrameProcessor& p = *processors[k];
        StereoFrameResult r;
        std::string why;
        bool ok;
        if (k == 0 || variants[k].own_disparity) {
          ok = p.processImages(left, right, camera, T_fixed_sensor, base, truth.t, &r, &why);
        } else if (processors[0]->disparity().empty()) {
          continue;  // the first variant refused the pair: so would this one
        } else {
          ok = p.processDisparity(processors[0]->disparity(), processors[0]->disparityCamera(),
                                  T_fixed_sensor, base, truth.t, &r, &why,
                                  processors[0]->coarseDisparity());
        }
        if (detectors[k]) {
          // The obstacle-detection nodelet's work on the same disparity message: the range
          // image within [min_depth, max_depth], 003's detector with the reported pose (tf).
          // It runs on every disparity, also on the frames the map skips (stationary), as the
          // nodelet does: its cues wait in the processor for the next map.
          const StereoFrameProcessor& src =
              k == 0 || variants[k].own_disparity ? p : *processors[0];
          const StereoCameraModel& cam = src.disparityCamera();
          if (!src.disparity().empty()) {
            reprojectDisparityOrganized(src.disparity(), cam, variants[k].detector_max_depth, &xyz);
            limitRangeImageDepth(variants[k].detector_min_depth, variants[k].detector_max_depth,
                                 &xyz);
            // The nodelet's ~decimation: every n-th pixel, f / n, the full image's margin.
            const int n = variants[k].detector_decimation;
            decimateRangeImage(xyz, n, &xyz_detect);
            if (detectors[k]->detect(xyz_detect, std::max(cam.fx, cam.fy) / n, T_fixed_sensor,
                                     &detection, cam.baseline * n)) {
              scorer.scoreDetection(detection, &result.scores[k].detection);
              if (variants[k].config.obstacle_cue) {
                raisedObstaclePoints(detection, xyz_detect, T_fixed_sensor, &cue_points, nullptr);
                p.addObstacleCue(truth.t, cue_points);
              }
            }
          }
        }
        // A stationary frame: the nodelet republishes the map (recomputed with the live cues,
        // StereoFrameResult::map_refreshed), and a consumer acts on it: score it too.
        const bool republished =
            r.mapper.status == FrameStatus::kStationary && p.mapper().safetyMap().width > 0;
        if (!ok && !republished) continue;
        if (r.mapper.status == FrameStatus::kIntegrated) {
          // The tilt the map used (the reported pose, re-levelled when the variant does so)
          // against the true camera's.
          const FrameLevellingResult& lv = r.mapper.levelling;
          const Eigen::Isometry3d used = lv.applied
                                             ? levelledPose(T_fixed_sensor, lv.roll_deg * kDegToRad,
                                                            lv.pitch_deg * kDegToRad, lv.dz)
                                                   .cast<double>()
                                             : fp.reported_left_optical;
          SceneScore& sc = result.scores[k];
          ++sc.tilt_frames;
          addTiltError(used, fp.true_left_optical, &sc.tilt_used);
          addTiltError(fp.reported_left_optical, fp.true_left_optical, &sc.tilt_reported);
        }
        if (!options.image_dir.empty() &&
            std::find(options.image_frames.begin(), options.image_frames.end(),
                      static_cast<int>(i)) != options.image_frames.end()) {
          const SafetyMap world = mapInWorld(p.mapper().safetyMap(), T_world_odom, gt);
          LabelGrid gt_grid;
          gt_grid.min_u = gt.min_u;
          gt_grid.min_v = gt.min_v;
          gt_grid.width = gt.width;
          gt_grid.height = gt.height;
          gt_grid.resolution = gt.resolution;
          gt_grid.labels = gt.labels;
          ConfusionCounts counts;
          std::vector<CellOutcome> outcomes;
          countConfusion(world, gt_grid, &counts, &outcomes);
          const std::string name = "seed" + std::to_string(scene.seed) + "_frame" +
                                   std::to_string(i) + "_" + variants[k].name;
          // Beside the picture, the map's segments in the world frame (for development: why a
          // segment is what it is).
          {
            const SafetyMap& sm = p.mapper().safetyMap();
            std::ofstream seg_txt(options.image_dir + "/" + name + "_segments.txt");
            seg_txt << "# robot segment " << sm.robot_segment
                    << "; id label cells boundary island reachable obstacle plane_valid slope_deg "
                       "rms_m points w centroid_world(x y z)\n";
            for (const SegmentInfo& si : sm.segments) {
              const Eigen::Vector2d cw =
                  T_world_odom * Eigen::Vector2d(si.plane.centroid.x(), si.plane.centroid.y());
              char line[256];
              std::snprintf(line, sizeof(line),
                            "%d %s %zu %d %d %d %d %d %.2f %.3f %zu %d %.2f %.2f %.3f\n", si.id,
                            toString(si.label), si.cells.size(), si.num_boundary, si.island ? 1 : 0,
                            si.reachable ? 1 : 0, si.obstacle ? 1 : 0, si.plane.valid ? 1 : 0,
                            si.plane.slope_deg, si.plane.residual_rms, si.plane.num_points,
                            si.indexed_height, cw.x(), cw.y(), si.plane.centroid.z());
              seg_txt << line;
            }
            // Every examined cell: where it is, what the map and the ground truth call it, its
            // segment, its column's indexed height and its measured surface height.
            std::ofstream cells_csv(options.image_dir + "/" + name + "_cells.csv");
            cells_csv << "x,y,label,gt,segment,w,surface_z,ground_z,lo_m2,lo_m1,lo_0,lo_1,n_m1,n_0,"
                         "mass_m1,mass_0,mass_1\n";
            const HeightMap& hm = p.mapper().heightMap();
            for (int v = sm.min_v; v < sm.min_v + sm.height; ++v) {
              for (int u = sm.min_u; u < sm.min_u + sm.width; ++u) {
                const int c = sm.index(u, v);
                if (sm.labels[c] == SafetyLabel::kUnexamined) continue;
                const Eigen::Vector2d pw = T_world_odom * sm.cellCenter(u, v);
                const int gu = static_cast<int>(std::lround(pw.x() / gt.resolution));
                const int gv = static_cast<int>(std::lround(pw.y() / gt.resolution));
                const SafetyLabel g = gt_grid.at(gu, gv);
                const int hu = u - hm.minU(), hv = v - hm.minV();
                const bool in_hm = hu >= 0 && hv >= 0 && hu < hm.width() && hv < hm.height();
                const float sz = in_hm ? hm.surfaceHeightAtIndex(hv * hm.width() + hu)
                                       : std::numeric_limits<float>::quiet_NaN();
                const float gz = in_hm ? hm.groundHeightAtIndex(hv * hm.width() + hu)
                                       : std::numeric_limits<float>::quiet_NaN();
                const VoxelGrid& vg = p.mapper().grid();
                int lo[4] = {0, 0, 0, 0};
                int np[2] = {0, 0};
                float mass[3] = {0.0f, 0.0f, 0.0f};
                for (int w = -2; w <= 1; ++w) {
                  const VoxelIndex vi{u, v, w};
                  if (!vg.contains(vi)) continue;
                  lo[w + 2] = vg.logOdds(vi);
                  if (w >= -1) mass[w + 1] = vg.hitMass(vi);
                  if (w == -1 || w == 0) np[w + 1] = static_cast<int>(vg.points(vi).size);
                }
                char line[260];
                std::snprintf(line, sizeof(line),
                              "%.2f,%.2f,%s,%s,%d,%d,%.3f,%.3f,%d,%d,%d,%d,%d,%d,%.0f,%.0f,%.0f\n",
                              pw.x(), pw.y(), toString(sm.labels[c]), toString(g), sm.segment[c],
                              static_cast<int>(sm.column_height[c]), sz, gz, lo[0], lo[1], lo[2],
                              lo[3], np[0], np[1], mass[0], mass[1], mass[2]);
                cells_csv << line;
              }
            }
          }
          // The disparity this variant mapped against the rendered depth (for development: how
          // many readings are wrong, and by how much, in which image rows).
          {
            const StereoFrameProcessor& src =
                k == 0 || variants[k].own_disparity ? p : *processors[0];
            writeDisparityError(src.disparity(), src.disparityCamera(), depth,
                                options.image_dir + "/" + name);
            cv::imwrite(options.image_dir + "/" + name + "_left.png", left);
          }
          cv::imwrite(
              options.image_dir + "/" + name + ".png",
              mapBesideGroundTruth(world, gt_grid, outcomes, Eigen::Vector3d(truth.x, truth.y, 0.0),
                                   truth.yaw, name));
        }
        if (trace)
          writeCellTrace(p.mapper(), options.trace_cells, T_world_odom, base, i, truth.t,
                         variants[k].name, &trace);
        scorer.scoreMap(static_cast<int>(k), p.mapper().safetyMap(), truth.t, T_world_odom, robot,
                        &result.scores[k]);
      }
      ++result.frames;
    }
    for (SceneScore& s : result.scores)
      scorer.finish(&s);
  } catch (const std::exception& e) {
    result.error = e.what();
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace dataset
}  // namespace stereo_safety_map
