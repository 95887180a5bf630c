#include "stereo_safety_map/ros/occupancy_grid_2d_conversions.h"

#include <cstring>

namespace stereo_safety_map {

OccupancyGrid2DClass occupancyGrid2DClass(std::uint8_t g, int free_threshold,
                                          int occupied_threshold) {
  if (g < free_threshold) return OccupancyGrid2DClass::kFree;
  if (g > occupied_threshold) return OccupancyGrid2DClass::kOccupied;
  return OccupancyGrid2DClass::kUnknown;
}

std::int8_t occupancyGrid2DValue(std::uint8_t g, int free_threshold, int occupied_threshold) {
  return kOccupancyGrid2DValueTable[static_cast<int>(occupancyGrid2DClass(g, free_threshold,
                                                                          occupied_threshold))]
      .value;
}

std::array<std::int8_t, 256> occupancyGrid2DLookup(int free_threshold, int occupied_threshold) {
  std::array<std::int8_t, 256> lut{};
  for (int g = 0; g < 256; ++g)
    lut[g] = occupancyGrid2DValue(static_cast<std::uint8_t>(g), free_threshold, occupied_threshold);
  return lut;
}

void toOccupancyGrid(const OccupancyGrid2D& grid, const std_msgs::Header& header,
                     nav_msgs::OccupancyGrid* out, cv::Mat* image) {
  const OccupancyGrid2DConfig& c = grid.config();
  const double l = c.resolution;
  out->header = header;
  out->info.map_load_time = header.stamp;
  out->info.resolution = static_cast<float>(l);
  out->info.width = static_cast<std::uint32_t>(grid.sizeU());
  out->info.height = static_cast<std::uint32_t>(grid.sizeV());
  out->info.origin.position.x = (grid.minIndex().u - 0.5) * l;
  out->info.origin.position.y = (grid.minIndex().v - 0.5) * l;
  out->info.origin.position.z = 0.0;
  out->info.origin.orientation.x = 0.0;
  out->info.origin.orientation.y = 0.0;
  out->info.origin.orientation.z = 0.0;
  out->info.origin.orientation.w = 1.0;

  // Row r of the image is v = min_v + r, column c is u = min_u + c: the message's row-major
  // order (row 0 at the origin, y growing with the row).
  grid.toImage(image);
  const std::array<std::int8_t, 256> lut =
      occupancyGrid2DLookup(c.free_threshold, c.occupied_threshold);
  out->data.resize(static_cast<std::size_t>(grid.sizeU()) * grid.sizeV());
  for (int r = 0; r < image->rows; ++r) {
    const std::uint8_t* src = image->ptr<std::uint8_t>(r);
    std::int8_t* dst = out->data.data() + static_cast<std::size_t>(r) * image->cols;
    for (int col = 0; col < image->cols; ++col)
      dst[col] = lut[src[col]];
  }
}

}  // namespace stereo_safety_map
