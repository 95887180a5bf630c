// Fronto-parallel textured layers over a background, rendered as a rectified pair with
// occlusions: the disparity tests' synthetic input whose true disparity is known by
// construction (test_disparity_reference.cpp, test_disparity_block_matcher.cpp).
#pragma once

#include <opencv2/core.hpp>

#include <vector>

namespace stereo_safety_map {
namespace test {

struct StereoLayer {
  cv::Rect rect;    ///< the layer's extent in texture coordinates (left image columns)
  int disparity;    ///< [px]
  cv::Mat texture;  ///< CV_8UC1, at least rows x (cols + largest disparity)
};

/// Each camera sees the nearest (largest disparity) layer; the surface point at left column x
/// appears at right column x - disparity. Pixels no layer covers are 0.
inline void renderLayers(const std::vector<StereoLayer>& layers, int rows, int cols, cv::Mat* left,
                         cv::Mat* right) {
  left->create(rows, cols, CV_8UC1);
  right->create(rows, cols, CV_8UC1);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const StereoLayer* l_in = nullptr;
      const StereoLayer* r_in = nullptr;
      for (const StereoLayer& l : layers) {
        if (y < l.rect.y || y >= l.rect.y + l.rect.height) continue;
        if (x >= l.rect.x && x < l.rect.x + l.rect.width &&
            (l_in == nullptr || l.disparity > l_in->disparity))
          l_in = &l;
        const int xs = x + l.disparity;
        if (xs >= l.rect.x && xs < l.rect.x + l.rect.width &&
            (r_in == nullptr || l.disparity > r_in->disparity))
          r_in = &l;
      }
      left->at<uchar>(y, x) = l_in ? l_in->texture.at<uchar>(y, x) : 0;
      right->at<uchar>(y, x) = r_in ? r_in->texture.at<uchar>(y, x + r_in->disparity) : 0;
    }
  }
}

}  // namespace test
}  // namespace stereo_safety_map
