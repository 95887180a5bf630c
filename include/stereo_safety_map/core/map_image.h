// Pictures of safety maps in the colours of paper 000 Fig. 4(a), for reports and debugging:
// a map, the ground truth and the per-cell evaluation outcome side by side.
//
// ROS-free (OpenCV only).
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/safety_map.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <functional>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// Pixels per map cell in the pictures.
constexpr int kMapImageScale = 4;

/// 000 Fig. 4(a): Non-ground black, Level white, Inclined yellow, Unknown light grey,
/// Unexamined dark grey (BGR).
cv::Vec3b labelColour(SafetyLabel label);
/// Potential drop-off edges: blue (000 Fig. 4(a)).
cv::Vec3b dropOffColour();
/// TP dark, TN pale, FP orange, FN red, unclassified grey (BGR).
cv::Vec3b outcomeColour(CellOutcome outcome);

/// One panel of the map's window, +x right, +y up, kMapImageScale pixels per cell;
/// `colour(u, v, k)` gives the colour of the cell with global index (u, v) and map index k.
cv::Mat mapPanel(const SafetyMap& map, const std::function<cv::Vec3b(int u, int v, int k)>& colour);
/// The robot as a red triangle (000 Fig. 7) at `position` (fixed frame) heading `yaw`.
void drawRobot(cv::Mat* image, const SafetyMap& map, const Eigen::Vector3d& position, double yaw);
/// The image with a white title bar above it.
cv::Mat titled(const cv::Mat& image, const std::string& title);
/// A legend of the label and outcome colours, `width` pixels wide.
cv::Mat mapLegend(int width);

/// Map | ground truth | outcomes, with the robot and a legend. `outcomes` as from
/// countConfusion() (may be empty: all unclassified). A non-finite yaw draws no robot heading.
cv::Mat mapBesideGroundTruth(const SafetyMap& map, const LabelGrid& gt,
                             const std::vector<CellOutcome>& outcomes, const Eigen::Vector3d& robot,
                             double yaw, const std::string& title);

}  // namespace stereo_safety_map
