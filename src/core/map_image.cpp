#include "stereo_safety_map/core/map_image.h"

#include <opencv2/imgproc.hpp>

#include <cmath>

namespace stereo_safety_map {

cv::Vec3b labelColour(SafetyLabel l) {
  switch (l) {
    case SafetyLabel::kNonGround:
      return {0, 0, 0};  // black
    case SafetyLabel::kLevel:
      return {255, 255, 255};  // white
    case SafetyLabel::kInclined:
      return {0, 230, 255};  // yellow
    case SafetyLabel::kUnknown:
      return {200, 200, 200};  // light grey
    case SafetyLabel::kUnexamined:
    default:
      return {105, 105, 105};  // dark grey
  }
}
cv::Vec3b dropOffColour() {
  return {255, 0, 0};  // blue
}

cv::Vec3b outcomeColour(CellOutcome o) {
  switch (o) {
    case CellOutcome::kTruePositive:
      return {40, 40, 40};
    case CellOutcome::kTrueNegative:
      return {235, 245, 235};
    case CellOutcome::kFalsePositive:
      return {0, 140, 255};  // orange
    case CellOutcome::kFalseNegative:
      return {0, 0, 230};  // red
    default:
      return {170, 170, 170};
  }
}

cv::Mat mapPanel(const SafetyMap& map,
                 const std::function<cv::Vec3b(int u, int v, int k)>& colour) {
  cv::Mat img(map.height * kMapImageScale, map.width * kMapImageScale, CV_8UC3);
  for (int r = 0; r < map.height; ++r) {
    const int v = map.min_v + map.height - 1 - r;
    for (int c = 0; c < map.width; ++c) {
      const int u = map.min_u + c;
      img(cv::Rect(c * kMapImageScale, r * kMapImageScale, kMapImageScale, kMapImageScale)) =
          colour(u, v, map.index(u, v));
    }
  }
  return img;
}

void drawRobot(cv::Mat* img, const SafetyMap& map, const Eigen::Vector3d& position, double yaw) {
  const double px = (position.x() / map.resolution - map.min_u + 0.5) * kMapImageScale;
  const double py = (map.min_v + map.height - 0.5 - position.y() / map.resolution) * kMapImageScale;
  const double s = 3.0 * kMapImageScale;  // 000 Fig. 7: the robot is a red triangle
  if (!std::isfinite(px) || !std::isfinite(py) || std::abs(px) > 1e6 || std::abs(py) > 1e6) return;
  if (!std::isfinite(yaw)) {  // heading unknown: a dot
    cv::circle(*img, cv::Point(static_cast<int>(px), static_cast<int>(py)),
               static_cast<int>(0.6 * s), cv::Scalar(0, 0, 255), cv::FILLED, cv::LINE_AA);
    return;
  }
  std::vector<cv::Point> tri;
  for (double a : {0.0, 2.5, -2.5}) {
    const double r = a == 0.0 ? s : 0.7 * s;
    tri.emplace_back(static_cast<int>(px + r * std::cos(yaw + a)),
                     static_cast<int>(py - r * std::sin(yaw + a)));
  }
  cv::fillConvexPoly(*img, tri, cv::Scalar(0, 0, 255), cv::LINE_AA);
}

cv::Mat titled(const cv::Mat& img, const std::string& title) {
  cv::Mat out(img.rows + 28, img.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  img.copyTo(out(cv::Rect(0, 28, img.cols, img.rows)));
  cv::putText(out, title, cv::Point(6, 20), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  return out;
}

cv::Mat mapLegend(int width) {
  cv::Mat out(52, width, CV_8UC3, cv::Scalar(255, 255, 255));
  struct Item {
    const char* name;
    cv::Vec3b c;
  };
  const Item row1[] = {{"Level", labelColour(SafetyLabel::kLevel)},
                       {"Inclined", labelColour(SafetyLabel::kInclined)},
                       {"Non-ground", labelColour(SafetyLabel::kNonGround)},
                       {"Unknown", labelColour(SafetyLabel::kUnknown)},
                       {"Unexamined", labelColour(SafetyLabel::kUnexamined)},
                       {"Drop-off edge", dropOffColour()}};
  const Item row2[] = {{"TP", outcomeColour(CellOutcome::kTruePositive)},
                       {"TN", outcomeColour(CellOutcome::kTrueNegative)},
                       {"FP", outcomeColour(CellOutcome::kFalsePositive)},
                       {"FN", outcomeColour(CellOutcome::kFalseNegative)},
                       {"unclassified", outcomeColour(CellOutcome::kUnclassified)}};
  auto draw = [&](const Item* items, int n, int y) {
    int x = 6;
    for (int i = 0; i < n; ++i) {
      cv::rectangle(out, cv::Rect(x, y, 14, 14), cv::Scalar(items[i].c), cv::FILLED);
      cv::rectangle(out, cv::Rect(x, y, 14, 14), cv::Scalar(90, 90, 90), 1);
      cv::putText(out, items[i].name, cv::Point(x + 18, y + 12), cv::FONT_HERSHEY_SIMPLEX, 0.42,
                  cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
      x += 28 + 8 * static_cast<int>(std::string(items[i].name).size());
    }
  };
  draw(row1, 6, 6);
  draw(row2, 5, 30);
  return out;
}

cv::Mat mapBesideGroundTruth(const SafetyMap& map, const LabelGrid& gt,
                             const std::vector<CellOutcome>& outcomes, const Eigen::Vector3d& robot,
                             double yaw, const std::string& title) {
  cv::Mat a = mapPanel(map, [&](int, int, int k) {
    return map.drop_off.size() == map.labels.size() && map.drop_off[k] ? dropOffColour()
                                                                       : labelColour(map.labels[k]);
  });
  cv::Mat b = mapPanel(map, [&](int u, int v, int) { return labelColour(gt.at(u, v)); });
  cv::Mat c = mapPanel(map, [&](int, int, int k) {
    return k < static_cast<int>(outcomes.size()) ? outcomeColour(outcomes[k])
                                                 : outcomeColour(CellOutcome::kUnclassified);
  });
  for (cv::Mat* m : {&a, &b, &c})
    drawRobot(m, map, robot, yaw);
  std::vector<cv::Mat> row = {titled(a, "safety map: " + title), titled(b, "ground truth"),
                              titled(c, "errors (unsafe = positive)")};
  cv::Mat sep(row[0].rows, 6, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat out;
  cv::hconcat(std::vector<cv::Mat>{row[0], sep, row[1], sep, row[2]}, out);
  cv::Mat full;
  cv::vconcat(out, mapLegend(out.cols), full);
  return full;
}

}  // namespace stereo_safety_map
