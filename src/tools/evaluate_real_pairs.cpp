// evaluate_real_pairs: the real-data check of the evaluation (docs/evaluation.md). Each real
// rectified pair of ../shared/data/real/ goes through the core pipeline in single-frame mode
// (core/real_pair_check.h: occ_t = one hit, decr = 0, seed radius 3 m), and its safety map is
// scored against the hand labels of its left image (test/data/real_labels/<set>/<name>.txt,
// core/image_labels.h): every labelled pixel with a valid disparity votes for the truth of the
// cell its 3D point falls in, and the map's labels are counted against those truths with the
// rates of 000 Sec. VII-A (Non-ground positive), coverage and per-class recall, exactly and with a
// one-cell tolerance at label boundaries. The camera's height and tilt above the map's dominant
// ground plane are compared with the reference values of the data folder's README (a check of the
// pose estimate, not of the labels). Writes real_pairs.json, real_pairs.md and one PNG per pair
// (left image with the labels | map | labels on the map's cells | errors; colours of 000
// Fig. 4(a)).
//
//   evaluate_real_pairs [--data DIR] [--labels DIR] [--out DIR] [--params YAML ...]
//                       [--set key=value ...]
//   (defaults: ../shared/data/real, test/data/real_labels, out/real_pairs; run from the repository)
//   --params / --set: the nodelets' parameter files and keys (config/disparity.yaml,
//   config/safety_map.yaml), as the other evaluators take them, so that a user's configuration
//   is scored on real pairs too; single-frame mode then overrides what it must (occ_t, decr,
//   seed radius). Without them the core's defaults run (the same values as the files').
//
// Exits 0 when every pair ran and was scored against its labels and every pair with a reference
// pose is within 5 cm and 1 deg of it; 1 otherwise (the scores are reported, not gated: seven
// hand-labelled frames are a measurement, not a threshold); 3 when the data folder is missing
// ("skipped: real data not present").
#include "stereo_safety_map/core/image_labels.h"
#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/core/real_pair_check.h"
#include "stereo_safety_map/ros/param_yaml.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace ssm = stereo_safety_map;

namespace {

constexpr double kHeightTolerance = 0.05;  // [m] "a few cm"
constexpr double kTiltTolerance = 1.0;     // [deg]

struct Pair {
  std::string set, name, left, right;
  ssm::StereoCameraModel camera;
  bool has_reference = false;
  double ref_height = 0.0, ref_pitch = 0.0;  // ../shared/data/real/README.md
};

bool isDir(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

// Hand-label colours (BGR): floor green, obstacle red, overhang magenta, drop-off blue, ignore
// yellow.
cv::Vec3b handLabelColour(ssm::ImageLabel l) {
  switch (l) {
    case ssm::ImageLabel::kFloor:
      return {0, 190, 0};
    case ssm::ImageLabel::kObstacle:
      return {0, 0, 230};
    case ssm::ImageLabel::kOverhang:
      return {230, 0, 230};
    case ssm::ImageLabel::kDropOff:
      return {230, 120, 0};
    case ssm::ImageLabel::kIgnore:
      return {0, 230, 230};
    default:
      return {0, 0, 0};
  }
}

// The left image with the hand labels blended in, `rows` high.
cv::Mat labelledImage(const cv::Mat& left, const cv::Mat& labels, int rows) {
  cv::Mat grey = left;
  if (left.channels() != 1) cv::cvtColor(left, grey, cv::COLOR_BGR2GRAY);
  cv::Mat img;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  for (int y = 0; y < img.rows && !labels.empty(); ++y)
    for (int x = 0; x < img.cols; ++x) {
      const auto l = static_cast<ssm::ImageLabel>(labels.at<std::uint8_t>(y, x));
      if (l == ssm::ImageLabel::kNone) continue;
      cv::Vec3b& p = img.at<cv::Vec3b>(y, x);
      const cv::Vec3b c = handLabelColour(l);
      for (int k = 0; k < 3; ++k)
        p[k] = static_cast<std::uint8_t>(0.6 * p[k] + 0.4 * c[k]);
    }
  cv::resize(img, img, cv::Size(rows * img.cols / img.rows, rows), 0, 0, cv::INTER_AREA);
  return ssm::titled(img, "left image, hand labels");
}

cv::Mat pairImage(const ssm::RealPairResult& r, const cv::Mat& left, const cv::Mat& labels,
                  const ssm::ImageLabelScore& score, const std::string& title) {
  const ssm::LabelGrid truth = ssm::truthLabelGrid(r.map, score.truth);
  const cv::Mat maps = ssm::mapBesideGroundTruth(r.map, truth, score.outcomes,
                                                 r.T_fixed_camera.translation(), 0.0, title);
  const cv::Mat cam = labelledImage(left, labels, r.map.height * ssm::kMapImageScale);
  cv::Mat padded(maps.rows, cam.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  cam.copyTo(padded(cv::Rect(0, 0, cam.cols, cam.rows)));
  cv::Mat out;
  cv::hconcat(
      std::vector<cv::Mat>{padded, cv::Mat(maps.rows, 6, CV_8UC3, cv::Scalar::all(255)), maps},
      out);
  return out;
}

std::string fmt(double v, int prec) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.*f", prec, v);
  return std::isfinite(v) ? b : "null";
}

// Percent for tables: "12.3" or "-" when undefined.
std::string pct(double v) {
  return std::isfinite(v) ? fmt(100.0 * v, 1) : "-";
}

std::string countsJson(const ssm::ConfusionCounts& c) {
  const ssm::ErrorRates r = ssm::errorRates(c);
  std::ostringstream os;
  os << "{\"tp\": " << c.tp << ", \"fp\": " << c.fp << ", \"fn\": " << c.fn << ", \"tn\": " << c.tn
     << ", \"unclassified_in_map\": " << c.unclassified_in_map
     << ", \"unclassified_in_labels\": " << c.unclassified_in_gt
     << ", \"fn_rate\": " << fmt(r.fn, 4) << ", \"fp_rate\": " << fmt(r.fp, 4) << "}";
  return os.str();
}

std::string scoreJson(const ssm::ImageLabelScore& s) {
  std::ostringstream os;
  os << "{\"truth_cells\": " << s.truth_cells << ", \"covered_cells\": " << s.covered_cells
     << ", \"coverage\": " << fmt(s.coverage(), 4)
     << ", \"truth_cells_beyond_rmax\": " << s.truth_cells_beyond
     << ", \"cells_tied\": " << s.cells_tied
     << ", \"cells_too_few_votes\": " << s.cells_too_few_votes
     << ", \"exact\": " << countsJson(s.exact)
     << ", \"tolerant_1_cell\": " << countsJson(s.tolerant) << ", \"classes\": {";
  bool first = true;
  for (int k = 1; k < ssm::kNumImageLabels; ++k) {
    const ssm::LabelClassScore& c = s.classes[k];
    os << (first ? "" : ", ") << "\"" << ssm::toString(static_cast<ssm::ImageLabel>(k))
       << "\": {\"pixels\": " << c.pixels
       << ", \"pixels_with_disparity\": " << c.pixels_with_disparity
       << ", \"pixels_voting\": " << c.pixels_voting << ", \"cells\": " << c.cells
       << ", \"cells_beyond_rmax\": " << c.cells_beyond << ", \"map_safe\": " << c.map_safe
       << ", \"map_non_ground\": " << c.map_non_ground << ", \"map_unknown\": " << c.map_unknown
       << ", \"recall\": " << fmt(c.recall(), 4)
       << ", \"recall_tolerant\": " << fmt(c.recallTolerant(), 4) << "}";
    first = false;
  }
  os << "}}";
  return os.str();
}

struct Outcome {
  std::string id;
  bool ok = false;
  ssm::ImageLabelScore score;
};

}  // namespace

int main(int argc, char** argv) {
  std::string data = "../shared/data/real", out = "out/real_pairs",
              labels_dir = "test/data/real_labels";
  std::vector<std::string> param_files, assignments;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--data" && i + 1 < argc) {
      data = argv[++i];
    } else if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--labels" && i + 1 < argc) {
      labels_dir = argv[++i];
    } else if (a == "--params" && i + 1 < argc) {
      param_files.push_back(argv[++i]);
    } else if (a == "--set" && i + 1 < argc) {
      assignments.push_back(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: evaluate_real_pairs [--data DIR] [--labels DIR] [--out DIR] "
                   "[--params YAML ...] [--set key=value ...]\n");
      return 2;
    }
  }
  ssm::RealPairCheckConfig config;
  {
    const std::string e = ssm::loadCoreParams(param_files, assignments, &config.processor);
    if (!e.empty()) {
      std::fprintf(stderr, "error: %s\n", e.c_str());
      return 2;
    }
  }
  if (!isDir(data)) {
    std::printf("skipped: real data not present (%s)\n", data.c_str());
    return 3;
  }
  std::vector<Pair> pairs;
  const std::string rt = data + "/indoor_robot_rtabmap";
  if (isDir(rt)) {
    ssm::StereoCameraModel cam;
    const std::string e =
        ssm::loadStereoCalibration(rt + "/stereo_left.yaml", rt + "/stereo_right.yaml", &cam);
    if (!e.empty()) {
      std::fprintf(stderr, "error: %s\n", e.c_str());
      return 1;
    }
    // Reference poses of the README (RANSAC plane on SGBM disparity).
    const struct {
      const char* frame;
      double h, pitch;
    } refs[] = {{"50", 1.107, 3.8}, {"60", 1.095, 6.2}};
    for (const auto& r : refs) {
      Pair p;
      p.set = "indoor_robot_rtabmap";
      p.name = r.frame;
      p.left = rt + "/left/" + r.frame + ".jpg";
      p.right = rt + "/right/" + r.frame + ".jpg";
      p.camera = cam;
      p.has_reference = true;
      p.ref_height = r.h;
      p.ref_pitch = r.pitch;
      pairs.push_back(p);
    }
  }
  const std::string bb = data + "/bumblebee2_boofcv";
  if (isDir(bb)) {
    ssm::StereoCameraModel cam;
    const std::string e = ssm::loadRectifiedCalibText(bb + "/rectified_calib.txt", 640, 480, &cam);
    if (!e.empty()) {
      std::fprintf(stderr, "error: %s\n", e.c_str());
      return 1;
    }
    for (const char* s : {"chair01", "chair02", "garden02", "stones01", "wall01"}) {
      Pair p;
      p.set = "bumblebee2_boofcv";
      p.name = s;
      p.left = bb + "/" + s + "_left_rect.png";
      p.right = bb + "/" + s + "_right_rect.png";
      p.camera = cam;
      pairs.push_back(p);
    }
  }
  if (mkdir(out.c_str(), 0775) != 0 && errno != EEXIST) {
    std::fprintf(stderr, "error: cannot create %s\n", out.c_str());
    return 1;
  }

  // Votes from the points the map was built from (the grid's reprojection range).
  const ssm::LabelScoringConfig scoring = ssm::LabelScoringConfig::forGrid(
      config.processor.mapper.grid.min_range, config.processor.mapper.grid.max_range);

  std::ostringstream json, md;
  json << "{\"tool\": \"evaluate_real_pairs\", \"height_tolerance_m\": " << kHeightTolerance
       << ", \"tilt_tolerance_deg\": " << kTiltTolerance << ", \"labels\": \"" << labels_dir
       << "\", \"min_pixels_per_cell\": " << scoring.min_pixels
       << ", \"tolerance_cells\": " << scoring.tolerance_cells << ", \"pairs\": [";
  md << "# Real-data check\n\nSingle-frame mode (core/real_pair_check.h): occ_t = incr_H (one "
        "hit), decr = 0, seed radius 3 m; camera levelled on a RANSAC plane, then re-levelled "
        "twice on the map's dominant ground plane.\n\n"
        "## Against the hand labels\n\n"
        "Labels: `test/data/real_labels/` (drawn by hand on the left images; README there). Each "
        "labelled pixel with a valid disparity in the grid's range votes for the cell its 3D point "
        "falls in; a cell's truth is the majority of at least "
     << scoring.min_pixels
     << " votes (floor safe; obstacle, overhang, drop_off unsafe). Rates of 000 Sec. VII-A "
        "(Non-ground positive) over the truth cells within R_max that the map classifies; "
        "coverage = classified / truth cells within R_max (Unknown counts against it); recall = "
        "share of a class's truth cells the map labels right (floor safe, obstacle and overhang "
        "Non-ground, drop_off not safe; Unknown is a miss). \"1 cell\": an error is forgiven when "
        "a truth cell within 1 cell (Chebyshev) has the map's class.\n\n"
        "| pair | truth cells (beyond R_max) | coverage | FN | FP | obstacle recall | overhang "
        "recall | floor safe | FN, 1 cell | FP, 1 cell | obstacle recall, 1 cell | floor safe, 1 "
        "cell |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::ostringstream md_pixels, md_pose;
  md_pixels
      << "\nLabelled pixels with a valid disparity, per class (with disparity / labelled):\n\n"
         "| pair | floor | obstacle | overhang | drop_off |\n|---|---|---|---|---|\n";
  md_pose << "\n## Camera pose (map's dominant ground plane)\n\nPass: within "
          << kHeightTolerance * 100 << " cm and " << kTiltTolerance
          << " deg of the README's reference (pairs that have one).\n\n"
             "| pair | height [m] | tilt [deg] | roll [deg] | reference | plane label | plane "
             "cells | Level / Inclined / Non-ground cells | result |\n"
             "|---|---|---|---|---|---|---|---|---|\n";
  std::vector<Outcome> outcomes;
  int failures = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const Pair& p = pairs[i];
    const std::string id = p.set + "/" + p.name;
    const cv::Mat left = cv::imread(p.left, cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(p.right, cv::IMREAD_GRAYSCALE);
    ssm::RealPairResult r;
    const bool ok =
        !left.empty() && !right.empty() && ssm::checkRealPair(left, right, p.camera, config, &r);
    if (left.empty() || right.empty()) r.error = "cannot read the images";

    // Hand labels.
    Outcome o;
    o.id = id;
    std::string label_error;
    cv::Mat label_image;
    ssm::ImageLabels labels;
    const std::string label_file = labels_dir + "/" + p.set + "/" + p.name + ".txt";
    label_error = ssm::loadImageLabels(label_file, &labels);
    if (label_error.empty()) label_error = ssm::rasteriseImageLabels(labels, &label_image);
    if (label_error.empty() && ok)
      label_error = ssm::scoreAgainstImageLabels(label_image, r.disparity, p.camera,
                                                 r.T_fixed_camera, r.map, scoring, &o.score);
    o.ok = ok && label_error.empty();

    std::string verdict = "no reference";
    if (!ok) {
      verdict = "error: " + r.error;
      ++failures;
    } else if (p.has_reference) {
      const bool pass = std::abs(r.map_plane.camera_height - p.ref_height) <= kHeightTolerance &&
                        std::abs(r.map_plane.pitch_deg - p.ref_pitch) <= kTiltTolerance;
      verdict = pass ? "pass" : "FAIL";
      failures += pass ? 0 : 1;
    }
    if (ok && !label_error.empty()) {
      std::fprintf(stderr, "error: %s: labels: %s\n", id.c_str(), label_error.c_str());
      ++failures;
    }
    std::printf(
        "%-28s height %s m, tilt %s deg, roll %s deg, plane %s (%d cells)%s: %s\n", id.c_str(),
        fmt(r.map_plane.camera_height, 3).c_str(), fmt(r.map_plane.pitch_deg, 2).c_str(),
        fmt(r.map_plane.roll_deg, 2).c_str(), ssm::toString(r.map_plane.label), r.map_plane.cells,
        p.has_reference
            ? (" [reference " + fmt(p.ref_height, 3) + " m, " + fmt(p.ref_pitch, 1) + " deg]")
                  .c_str()
            : "",
        verdict.c_str());
    const std::string png = p.set + "_" + p.name + ".png";
    if (o.ok) {
      cv::imwrite(out + "/" + png, pairImage(r, left, label_image, o.score, p.name));
    }
    const ssm::ImageLabelScore& s = o.score;
    json << (i ? ", " : "") << "{\"pair\": \"" << id << "\", \"ok\": " << (ok ? "true" : "false")
         << ", \"error\": \"" << r.error << "\", \"points\": " << r.points
         << ", \"height_m\": " << fmt(r.map_plane.camera_height, 4)
         << ", \"tilt_deg\": " << fmt(r.map_plane.pitch_deg, 3)
         << ", \"roll_deg\": " << fmt(r.map_plane.roll_deg, 3)
         << ", \"bootstrap_height_m\": " << fmt(r.bootstrap.camera_height, 4)
         << ", \"bootstrap_tilt_deg\": " << fmt(r.bootstrap.pitch_deg, 3) << ", \"plane_label\": \""
         << ssm::toString(r.map_plane.label) << "\", \"plane_cells\": " << r.map_plane.cells
         << ", \"level_cells\": " << r.level_cells << ", \"inclined_cells\": " << r.inclined_cells
         << ", \"non_ground_cells\": " << r.non_ground_cells << ", \"reference\": "
         << (p.has_reference ? "{\"height_m\": " + fmt(p.ref_height, 3) +
                                   ", \"tilt_deg\": " + fmt(p.ref_pitch, 1) + "}"
                             : std::string("null"))
         << ", \"pose_result\": \"" << verdict << "\", \"label_file\": \"" << label_file
         << "\", \"label_error\": \"" << label_error
         << "\", \"labels\": " << (o.ok ? scoreJson(s) : std::string("null")) << ", \"image\": \""
         << (o.ok ? png : "") << "\"}";
    md_pose << "| " << id << " | " << fmt(r.map_plane.camera_height, 3) << " | "
            << fmt(r.map_plane.pitch_deg, 2) << " | " << fmt(r.map_plane.roll_deg, 2) << " | "
            << (p.has_reference ? fmt(p.ref_height, 3) + " m, " + fmt(p.ref_pitch, 1) + " deg"
                                : "none")
            << " | " << ssm::toString(r.map_plane.label) << " | " << r.map_plane.cells << " | "
            << r.level_cells << " / " << r.inclined_cells << " / " << r.non_ground_cells << " | "
            << verdict << " |\n";
    if (!o.ok) {
      md << "| " << id << " | error: " << (ok ? label_error : r.error)
         << " | | | | | | | | | | |\n";
      outcomes.push_back(o);
      continue;
    }
    const ssm::ErrorRates e0 = ssm::errorRates(s.exact), e1 = ssm::errorRates(s.tolerant);
    const ssm::LabelClassScore& fl = s.classes[static_cast<int>(ssm::ImageLabel::kFloor)];
    const ssm::LabelClassScore& ob = s.classes[static_cast<int>(ssm::ImageLabel::kObstacle)];
    const ssm::LabelClassScore& ov = s.classes[static_cast<int>(ssm::ImageLabel::kOverhang)];
    md << "| " << id << " | " << s.truth_cells << " (" << s.truth_cells_beyond << ") | "
       << pct(s.coverage()) << " | " << pct(e0.fn) << " | " << pct(e0.fp) << " | "
       << pct(ob.recall()) << " | " << pct(ov.recall()) << " | " << pct(fl.recall()) << " | "
       << pct(e1.fn) << " | " << pct(e1.fp) << " | " << pct(ob.recallTolerant()) << " | "
       << pct(fl.recallTolerant()) << " |\n";
    md_pixels << "| " << id;
    for (ssm::ImageLabel l : {ssm::ImageLabel::kFloor, ssm::ImageLabel::kObstacle,
                              ssm::ImageLabel::kOverhang, ssm::ImageLabel::kDropOff}) {
      const ssm::LabelClassScore& c = s.classes[static_cast<int>(l)];
      md_pixels << " | "
                << (c.pixels
                        ? std::to_string(c.pixels_with_disparity) + " / " +
                              std::to_string(c.pixels) + " (" +
                              pct(static_cast<double>(c.pixels_with_disparity) / c.pixels) + " %)"
                        : std::string("-"));
    }
    md_pixels << " |\n";
    outcomes.push_back(o);
  }
  json << "], \"failures\": " << failures << "}\n";
  md << "\nPercent; \"-\" = no cell of that kind.\n" << md_pixels.str() << md_pose.str() << "\n";
  for (const Pair& p : pairs)
    md << "![" << p.set << "/" << p.name << "](" << p.set << "_" << p.name << ".png)\n";
  std::ofstream(out + "/real_pairs.json") << json.str();
  std::ofstream(out + "/real_pairs.md") << md.str();

  // The table on stdout: 000 Sec. VII-A rates, coverage and recall, exact and with 1 cell.
  std::printf(
      "\nagainst the hand labels (%%; exact | 1-cell tolerance; obst = obstacle recall, "
      "floor = floor cells safe):\n");
  std::printf("%-28s %6s %6s %6s %6s %6s %6s | %6s %6s %6s %6s\n", "pair", "cells", "cover", "FN",
              "FP", "obst", "floor", "FN", "FP", "obst", "floor");
  for (const Outcome& o : outcomes) {
    if (!o.ok) {
      std::printf("%-28s not scored\n", o.id.c_str());
      continue;
    }
    const ssm::ImageLabelScore& s = o.score;
    const ssm::ErrorRates e0 = ssm::errorRates(s.exact), e1 = ssm::errorRates(s.tolerant);
    const ssm::LabelClassScore& fl = s.classes[static_cast<int>(ssm::ImageLabel::kFloor)];
    const ssm::LabelClassScore& ob = s.classes[static_cast<int>(ssm::ImageLabel::kObstacle)];
    std::printf("%-28s %6d %6s %6s %6s %6s %6s | %6s %6s %6s %6s\n", o.id.c_str(), s.truth_cells,
                pct(s.coverage()).c_str(), pct(e0.fn).c_str(), pct(e0.fp).c_str(),
                pct(ob.recall()).c_str(), pct(fl.recall()).c_str(), pct(e1.fn).c_str(),
                pct(e1.fp).c_str(), pct(ob.recallTolerant()).c_str(),
                pct(fl.recallTolerant()).c_str());
  }
  std::printf(
      "wrote %s/real_pairs.md; %d failure(s) (a pair that did not run or was not scored, "
      "or a pose off its reference)\n",
      out.c_str(), failures);
  return failures == 0 ? 0 : 1;
}
