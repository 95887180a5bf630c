// evaluate_real_pairs: the real-data check of the evaluation (docs/evaluation.md). Each real
// rectified pair of ../shared/data/real/ goes through the core pipeline in single-frame mode
// (core/real_pair_check.h: occ_t = one hit, decr = 0, seed radius 3 m); the camera's height and
// tilt above the dominant ground plane are read back from the safety map and compared with the
// reference values of that folder's README. Writes real_pairs.json, real_pairs.md and one PNG of
// each map (colours of 000 Fig. 4(a)).
//
//   evaluate_real_pairs [--data DIR] [--out DIR]
//
// Exits 0 when every pair with a reference is within 5 cm and 1 deg and its floor is Level,
// 1 when one is not, 3 when the data folder is missing ("skipped: real data not present").
#include "stereo_safety_map/core/real_pair_check.h"

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

cv::Vec3b colour(ssm::SafetyLabel l) {  // 000 Fig. 4(a), BGR
  switch (l) {
    case ssm::SafetyLabel::kNonGround:
      return {0, 0, 0};
    case ssm::SafetyLabel::kLevel:
      return {255, 255, 255};
    case ssm::SafetyLabel::kInclined:
      return {0, 230, 255};
    case ssm::SafetyLabel::kUnknown:
      return {200, 200, 200};
    default:
      return {105, 105, 105};
  }
}

cv::Mat mapImage(const ssm::SafetyMap& m, const cv::Mat& left, const std::string& title) {
  const int s = 4;
  cv::Mat img(m.height * s, m.width * s, CV_8UC3);
  for (int r = 0; r < m.height; ++r) {
    const int v = m.min_v + m.height - 1 - r;
    for (int c = 0; c < m.width; ++c) {
      const int k = m.index(m.min_u + c, v);
      const cv::Vec3b col =
          !m.drop_off.empty() && m.drop_off[k] ? cv::Vec3b(255, 0, 0) : colour(m.labels[k]);
      img(cv::Rect(c * s, r * s, s, s)) = col;
    }
  }
  // Camera (x forward in the levelled frame) as a red triangle at the robot's cell.
  const int px = (m.robot_u - m.min_u) * s + s / 2,
            py = (m.min_v + m.height - 1 - m.robot_v) * s + s / 2;
  std::vector<cv::Point> tri = {{px + 12, py}, {px - 8, py - 7}, {px - 8, py + 7}};
  cv::fillConvexPoly(img, tri, cv::Scalar(0, 0, 255), cv::LINE_AA);
  cv::Mat cam;
  cv::Mat grey = left.channels() == 1 ? left : cv::Mat();
  if (grey.empty()) cv::cvtColor(left, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(grey, cam, cv::COLOR_GRAY2BGR);
  cv::resize(cam, cam, cv::Size(img.rows * cam.cols / cam.rows, img.rows));
  cv::Mat out;
  cv::hconcat(cam, img, out);
  cv::Mat framed(out.rows + 28, out.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  out.copyTo(framed(cv::Rect(0, 28, out.cols, out.rows)));
  cv::putText(framed, title, cv::Point(6, 20), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0),
              1, cv::LINE_AA);
  return framed;
}

std::string fmt(double v, int prec) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.*f", prec, v);
  return std::isfinite(v) ? b : "null";
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = "../shared/data/real", out = "out/real_pairs";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--data" && i + 1 < argc) {
      data = argv[++i];
    } else if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else {
      std::fprintf(stderr, "usage: evaluate_real_pairs [--data DIR] [--out DIR]\n");
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

  std::ostringstream json, md;
  json << "{\"tool\": \"evaluate_real_pairs\", \"height_tolerance_m\": " << kHeightTolerance
       << ", \"tilt_tolerance_deg\": " << kTiltTolerance << ", \"pairs\": [";
  md << "# Real-data check\n\nSingle-frame mode (core/real_pair_check.h): occ_t = incr_H (one "
        "hit), decr = 0, seed radius 3 m; camera levelled on a RANSAC plane, then re-levelled "
        "twice on the map's dominant ground plane. Height and tilt are those of the final map's "
        "plane. Pass: within "
     << kHeightTolerance * 100 << " cm and " << kTiltTolerance
     << " deg of the README's reference and the floor Level.\n\n"
        "| pair | height [m] | tilt [deg] | roll [deg] | reference | floor label | floor cells | "
        "Level / Inclined / Non-ground cells | result |\n|---|---|---|---|---|---|---|---|---|\n";
  int failures = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const Pair& p = pairs[i];
    const cv::Mat left = cv::imread(p.left, cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(p.right, cv::IMREAD_GRAYSCALE);
    ssm::RealPairResult r;
    const bool ok = !left.empty() && !right.empty() &&
                    ssm::checkRealPair(left, right, p.camera, ssm::RealPairCheckConfig(), &r);
    if (left.empty() || right.empty()) r.error = "cannot read the images";
    std::string verdict = "no reference";
    if (!ok) {
      verdict = "error: " + r.error;
      if (p.has_reference) ++failures;
    } else if (p.has_reference) {
      const bool pass = std::abs(r.map_plane.camera_height - p.ref_height) <= kHeightTolerance &&
                        std::abs(r.map_plane.pitch_deg - p.ref_pitch) <= kTiltTolerance &&
                        r.map_plane.label == ssm::SafetyLabel::kLevel;
      verdict = pass ? "pass" : "FAIL";
      failures += pass ? 0 : 1;
    }
    const std::string id = p.set + "/" + p.name;
    std::printf(
        "%-28s height %s m, tilt %s deg, roll %s deg, floor %s (%d cells)%s: %s\n", id.c_str(),
        fmt(r.map_plane.camera_height, 3).c_str(), fmt(r.map_plane.pitch_deg, 2).c_str(),
        fmt(r.map_plane.roll_deg, 2).c_str(), ssm::toString(r.map_plane.label), r.map_plane.cells,
        p.has_reference
            ? (" [reference " + fmt(p.ref_height, 3) + " m, " + fmt(p.ref_pitch, 1) + " deg]")
                  .c_str()
            : "",
        verdict.c_str());
    const std::string png = p.set + "_" + p.name + ".png";
    if (ok) {
      char title[160];
      std::snprintf(title, sizeof(title), "%s: camera %.3f m above the floor, tilted %.2f deg (%s)",
                    id.c_str(), r.map_plane.camera_height, r.map_plane.pitch_deg,
                    ssm::toString(r.map_plane.label));
      cv::imwrite(out + "/" + png, mapImage(r.map, left, title));
    }
    json << (i ? ", " : "") << "{\"pair\": \"" << id << "\", \"ok\": " << (ok ? "true" : "false")
         << ", \"error\": \"" << r.error << "\", \"points\": " << r.points
         << ", \"height_m\": " << fmt(r.map_plane.camera_height, 4)
         << ", \"tilt_deg\": " << fmt(r.map_plane.pitch_deg, 3)
         << ", \"roll_deg\": " << fmt(r.map_plane.roll_deg, 3)
         << ", \"bootstrap_height_m\": " << fmt(r.bootstrap.camera_height, 4)
         << ", \"bootstrap_tilt_deg\": " << fmt(r.bootstrap.pitch_deg, 3) << ", \"floor_label\": \""
         << ssm::toString(r.map_plane.label) << "\", \"floor_cells\": " << r.map_plane.cells
         << ", \"level_cells\": " << r.level_cells << ", \"inclined_cells\": " << r.inclined_cells
         << ", \"non_ground_cells\": " << r.non_ground_cells << ", \"reference\": "
         << (p.has_reference ? "{\"height_m\": " + fmt(p.ref_height, 3) +
                                   ", \"tilt_deg\": " + fmt(p.ref_pitch, 1) + "}"
                             : std::string("null"))
         << ", \"result\": \"" << verdict << "\", \"image\": \"" << (ok ? png : "") << "\"}";
    md << "| " << id << " | " << fmt(r.map_plane.camera_height, 3) << " | "
       << fmt(r.map_plane.pitch_deg, 2) << " | " << fmt(r.map_plane.roll_deg, 2) << " | "
       << (p.has_reference ? fmt(p.ref_height, 3) + " m, " + fmt(p.ref_pitch, 1) + " deg" : "none")
       << " | " << ssm::toString(r.map_plane.label) << " | " << r.map_plane.cells << " | "
       << r.level_cells << " / " << r.inclined_cells << " / " << r.non_ground_cells << " | "
       << verdict << " |\n";
  }
  json << "], \"failures\": " << failures << "}\n";
  md << "\n";
  for (const Pair& p : pairs)
    md << "![" << p.set << "/" << p.name << "](" << p.set << "_" << p.name << ".png)\n";
  std::ofstream(out + "/real_pairs.json") << json.str();
  std::ofstream(out + "/real_pairs.md") << md.str();
  std::printf("wrote %s/real_pairs.md; %d of the pairs with a reference failed\n", out.c_str(),
              failures);
  return failures == 0 ? 0 : 1;
}
