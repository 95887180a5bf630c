#include "stereo_safety_map/ros/conversions.h"

#include <image_geometry/pinhole_camera_model.h>
#include <sensor_msgs/image_encodings.h>

#include <sensor_msgs/point_cloud2_iterator.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

namespace stereo_safety_map {

namespace {

template <typename T>
std::string str(const T& v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

bool positiveFinite(double v) {
  return std::isfinite(v) && v > 0.0;
}

}  // namespace

std::string checkCameraInfo(const sensor_msgs::CameraInfo& info, const char* which) {
  const std::string name = std::string(which) + " CameraInfo";
  if (info.width == 0 || info.height == 0) return name + " has an empty image size";
  for (double p : info.P) {
    if (!std::isfinite(p)) return name + " has a non-finite value in P";
  }
  if (info.P[11] != 0.0) {
    // image_geometry asserts it (P(2, 3) == 0) in places: an assertion aborts the process.
    return name + " has P[11] = " + str(info.P[11]) + ", must be 0 for a rectified camera";
  }
  if (!positiveFinite(info.P[0]) || !positiveFinite(info.P[5])) {
    return name + " has zero focal length (P[0] = " + str(info.P[0]) +
           ", P[5] = " + str(info.P[5]) + "); is the camera calibrated?";
  }
  return "";
}

std::string cameraModelFromCameraInfo(const sensor_msgs::CameraInfo& left,
                                      const sensor_msgs::CameraInfo& right,
                                      StereoCameraModel* model) {
  std::string err = checkCameraInfo(left, "left");
  if (err.empty()) err = checkCameraInfo(right, "right");
  if (!err.empty()) return err;
  if (!(right.P[3] < 0.0)) {
    return "right CameraInfo has zero baseline (P[3] = Tx = -fx B = " + str(right.P[3]) +
           ", must be < 0)";
  }
  if (left.width != right.width || left.height != right.height) {
    return "left and right CameraInfo sizes differ (" + str(left.width) + "x" + str(left.height) +
           " vs " + str(right.width) + "x" + str(right.height) + ")";
  }
  // Each camera through image_geometry::PinholeCameraModel (binning and ROI applied), the pair
  // checked here: image_geometry::StereoCameraModel::fromCameraInfo() asserts that fx, fy, cy and
  // the frame ids agree, and an assertion aborts the whole nodelet manager (fuzzing found it).
  // image_geometry throws from more than fromCameraInfo() (reducedResolution() of an ROI to
  // rectify with an unknown distortion model: fuzzing found it); everything it computes is read
  // inside the try.
  image_geometry::PinholeCameraModel lm, rm;
  cv::Size size;
  try {
    lm.fromCameraInfo(left);
    rm.fromCameraInfo(right);
    size = lm.reducedResolution();
  } catch (const std::exception& e) {
    return std::string("image_geometry refused the CameraInfo pair: ") + e.what();
  }
  auto differ = [](double a, double b) {
    return std::abs(a - b) > 1e-6 * std::max(1.0, std::abs(a));
  };
  if (differ(lm.fx(), rm.fx()) || differ(lm.fy(), rm.fy()) || differ(lm.cy(), rm.cy())) {
    return "left and right CameraInfo are not a rectified pair: fx " + str(lm.fx()) + " / " +
           str(rm.fx()) + ", fy " + str(lm.fy()) + " / " + str(rm.fy()) + ", cy " + str(lm.cy()) +
           " / " + str(rm.cy()) + " must agree";
  }
  StereoCameraModel m;
  m.fx = lm.fx();
  m.fy = lm.fy();
  m.cx = lm.cx();
  m.cy = lm.cy();
  m.cx_right = rm.cx();
  m.baseline = -rm.Tx() / rm.fx();  // as image_geometry::StereoCameraModel::baseline()
  m.width = size.width;
  m.height = size.height;
  err = m.validate();
  if (!err.empty()) return "camera model from CameraInfo: " + err;
  *model = m;
  return "";
}

sensor_msgs::CameraInfo toCameraInfo(const StereoCameraModel& model, bool right,
                                     const std_msgs::Header& header) {
  sensor_msgs::CameraInfo ci;
  ci.header = header;
  ci.width = static_cast<std::uint32_t>(std::max(0, model.width));
  ci.height = static_cast<std::uint32_t>(std::max(0, model.height));
  ci.distortion_model = "plumb_bob";
  ci.D.assign(5, 0.0);
  const double cx = right ? model.cx_right : model.cx;
  ci.K = {model.fx, 0.0, cx, 0.0, model.fy, model.cy, 0.0, 0.0, 1.0};
  ci.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  ci.P = {model.fx, 0.0,      cx,       right ? -model.fx * model.baseline : 0.0,
          0.0,      model.fy, model.cy, 0.0,
          0.0,      0.0,      1.0,      0.0};
  return ci;
}

std::string cameraModelForDisparity(const stereo_msgs::DisparityImage& disparity,
                                    const sensor_msgs::CameraInfo& left_info,
                                    StereoCameraModel* model) {
  if (!positiveFinite(disparity.f)) {
    return "DisparityImage has zero or non-finite focal length f = " + str(disparity.f);
  }
  if (!positiveFinite(disparity.T)) {
    return "DisparityImage has zero or non-finite baseline T = " + str(disparity.T);
  }
  std::string err = checkCameraInfo(left_info, "left");
  if (!err.empty()) return err;
  image_geometry::PinholeCameraModel left;
  cv::Size size;
  try {
    left.fromCameraInfo(left_info);
    size = left.reducedResolution();  // throws too (see cameraModelFromCameraInfo)
  } catch (const std::exception& e) {
    return std::string("image_geometry refused the left CameraInfo: ") + e.what();
  }
  if (static_cast<int>(disparity.image.width) != size.width ||
      static_cast<int>(disparity.image.height) != size.height) {
    return "DisparityImage size " + str(disparity.image.width) + "x" + str(disparity.image.height) +
           " does not match the left CameraInfo (" + str(size.width) + "x" + str(size.height) + ")";
  }
  StereoCameraModel left_model;
  left_model.fx = left.fx();
  left_model.fy = left.fy();
  left_model.cx = left.cx();
  left_model.cy = left.cy();
  left_model.width = size.width;
  left_model.height = size.height;
  DisparityMessageGeometry g;
  g.f = disparity.f;
  g.T = disparity.T;
  // The same function the offline path uses (StereoFrameProcessor::processImages).
  const StereoCameraModel m = messageCameraModel(g, left_model);
  err = m.validate();
  if (!err.empty()) return "camera model for the DisparityImage: " + err;
  *model = m;
  return "";
}

namespace {

// The structure of a DisparityImage's image: encoding, byte order, step, data size.
std::string checkDisparityStructure(const sensor_msgs::Image& img) {
  if (img.encoding != sensor_msgs::image_encodings::TYPE_32FC1) {
    return "DisparityImage has unsupported encoding '" + img.encoding + "' (need 32FC1)";
  }
  if (img.width == 0 || img.height == 0) return "DisparityImage is empty";
  if (img.is_bigendian) return "DisparityImage is big-endian (unsupported)";
  const std::size_t row_bytes = static_cast<std::size_t>(img.width) * sizeof(float);
  if (img.step < row_bytes || img.step % sizeof(float) != 0) {
    return "DisparityImage step " + str(img.step) + " does not fit width " + str(img.width) +
           " x 4 bytes";
  }
  const std::size_t needed = static_cast<std::size_t>(img.step) * (img.height - 1) + row_bytes;
  if (img.data.size() < needed) {
    return "DisparityImage data has " + str(img.data.size()) + " bytes, " + str(needed) +
           " needed for " + str(img.width) + "x" + str(img.height) + " with step " + str(img.step);
  }
  return "";
}

// Visits every pixel of a DisparityImage whose structure was checked: f(row, col, value) with
// the value made invalid (0) when not finite or outside [min_disparity, max_disparity].
template <typename F>
DisparityImageStats scanDisparity(const stereo_msgs::DisparityImage& msg, F&& f) {
  const sensor_msgs::Image& img = msg.image;
  const float lo = msg.min_disparity;
  const float hi = msg.max_disparity;
  const bool use_range = std::isfinite(lo) && std::isfinite(hi) && hi > lo;
  DisparityImageStats s;
  s.pixels = static_cast<std::size_t>(img.width) * img.height;
  for (std::uint32_t r = 0; r < img.height; ++r) {
    const std::uint8_t* src = img.data.data() + static_cast<std::size_t>(r) * img.step;
    for (std::uint32_t c = 0; c < img.width; ++c) {
      float d;
      std::memcpy(&d, src + c * sizeof(float), sizeof(float));  // need not be aligned
      if (!std::isfinite(d)) {
        ++s.non_finite;
        d = 0.0f;
      } else if (use_range && (d < lo || d > hi)) {
        ++s.out_of_range;
        d = 0.0f;
      }
      f(r, c, d);
    }
  }
  return s;
}

}  // namespace

std::string checkDisparityImage(const stereo_msgs::DisparityImage& msg,
                                DisparityImageStats* stats) {
  if (!positiveFinite(msg.f)) {
    return "DisparityImage has zero or non-finite focal length f = " + str(msg.f);
  }
  if (!positiveFinite(msg.T)) {
    return "DisparityImage has zero or non-finite baseline T = " + str(msg.T);
  }
  const std::string err = checkDisparityStructure(msg.image);
  if (!err.empty()) return err;
  const DisparityImageStats s = scanDisparity(msg, [](std::uint32_t, std::uint32_t, float) {});
  if (stats != nullptr) *stats = s;
  return "";
}

std::string disparityImageToMat(const stereo_msgs::DisparityImage& msg, cv::Mat* out,
                                DisparityImageStats* stats) {
  const std::string err = checkDisparityStructure(msg.image);
  if (!err.empty()) return err;
  out->create(static_cast<int>(msg.image.height), static_cast<int>(msg.image.width), CV_32FC1);
  const DisparityImageStats s = scanDisparity(
      msg, [out](std::uint32_t r, std::uint32_t c, float d) { out->ptr<float>(r)[c] = d; });
  if (stats != nullptr) *stats = s;
  return "";
}

namespace {

// The structure of a PointCloud2: fields x, y, z, byte order, steps, data size.
std::string checkCloudStructure(const sensor_msgs::PointCloud2& msg) {
  if (msg.is_bigendian) return "PointCloud2 is big-endian (unsupported)";
  const char* names[3] = {"x", "y", "z"};
  for (const char* name : names) {
    const auto it =
        std::find_if(msg.fields.begin(), msg.fields.end(),
                     [name](const sensor_msgs::PointField& f) { return f.name == name; });
    if (it == msg.fields.end()) return std::string("PointCloud2 has no field '") + name + "'";
    const auto same_name =
        std::count_if(msg.fields.begin(), msg.fields.end(),
                      [name](const sensor_msgs::PointField& f) { return f.name == name; });
    if (same_name > 1) {
      return std::string("PointCloud2 has ") + str(same_name) + " fields named '" + name +
             "' (ambiguous)";
    }
    if (it->datatype != sensor_msgs::PointField::FLOAT32 || it->count != 1) {
      return std::string("PointCloud2 field '") + name + "' is not a single FLOAT32 (datatype " +
             str(static_cast<int>(it->datatype)) + ", count " + str(it->count) + ")";
    }
    if (static_cast<std::size_t>(it->offset) + sizeof(float) > msg.point_step) {
      return std::string("PointCloud2 field '") + name + "' at offset " + str(it->offset) +
             " lies outside point_step " + str(msg.point_step);
    }
  }
  const std::size_t n = static_cast<std::size_t>(msg.width) * msg.height;
  if (n == 0) return "PointCloud2 is empty";
  if (static_cast<std::size_t>(msg.width) * msg.point_step > msg.row_step) {
    return "PointCloud2 row_step " + str(msg.row_step) + " is smaller than width x point_step (" +
           str(msg.width) + " x " + str(msg.point_step) + ")";
  }
  if (msg.data.size() < static_cast<std::size_t>(msg.row_step) * msg.height) {
    return "PointCloud2 data has " + str(msg.data.size()) + " bytes, row_step x height = " +
           str(static_cast<std::size_t>(msg.row_step) * msg.height) + " needed";
  }
  return "";
}

}  // namespace

namespace {

// Byte offsets of x, y, z (checkCloudStructure() made sure there is one field of each name).
void xyzOffsets(const sensor_msgs::PointCloud2& msg, std::uint32_t off[3]) {
  const char* names[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    off[a] = 0;
    for (const auto& f : msg.fields) {
      if (f.name == names[a]) {
        off[a] = f.offset;
        break;
      }
    }
  }
}

// Visits every point of a cloud whose structure was checked: f(x, y, z), row by row (rows may
// be padded: row_step >= width x point_step).
template <typename F>
void forEachPoint(const sensor_msgs::PointCloud2& msg, F&& f) {
  std::uint32_t off[3];
  xyzOffsets(msg, off);
  for (std::uint32_t r = 0; r < msg.height; ++r) {
    const std::uint8_t* row = msg.data.data() + static_cast<std::size_t>(r) * msg.row_step;
    for (std::uint32_t c = 0; c < msg.width; ++c) {
      const std::uint8_t* pt = row + static_cast<std::size_t>(c) * msg.point_step;
      float xyz[3];
      for (int a = 0; a < 3; ++a)
        std::memcpy(&xyz[a], pt + off[a], sizeof(float));  // need not be aligned
      f(xyz[0], xyz[1], xyz[2]);
    }
  }
}

}  // namespace

std::string checkPointCloud2(const sensor_msgs::PointCloud2& msg, CloudStats* stats) {
  const std::string err = checkCloudStructure(msg);
  if (!err.empty()) return err;
  CloudStats s;
  s.points = static_cast<std::size_t>(msg.width) * msg.height;
  forEachPoint(msg, [&s](float x, float y, float z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) ++s.non_finite;
  });
  if (stats != nullptr) *stats = s;
  return "";
}

std::string pointCloud2ToPoints(const sensor_msgs::PointCloud2& msg,
                                std::vector<Eigen::Vector3f>* points, CloudStats* stats) {
  points->clear();
  const std::string err = checkCloudStructure(msg);
  if (!err.empty()) return err;
  CloudStats s;
  s.points = static_cast<std::size_t>(msg.width) * msg.height;
  points->reserve(s.points);
  forEachPoint(msg, [&s, points](float x, float y, float z) {
    const Eigen::Vector3f p(x, y, z);
    if (p.allFinite()) {
      points->push_back(p);
    } else {
      ++s.non_finite;
    }
  });
  if (stats != nullptr) *stats = s;
  return "";
}

std::string rectifiedImageToGrey(const sensor_msgs::Image& msg, const char* which, cv::Mat* buffer,
                                 cv::Mat* grey) {
  namespace enc = sensor_msgs::image_encodings;
  int channels = 0;
  int code = -1;
  if (msg.encoding == enc::MONO8 || msg.encoding == enc::TYPE_8UC1) {
    channels = 1;
  } else if (msg.encoding == enc::BGR8) {
    channels = 3;
    code = cv::COLOR_BGR2GRAY;
  } else if (msg.encoding == enc::RGB8) {
    channels = 3;
    code = cv::COLOR_RGB2GRAY;
  } else if (msg.encoding == enc::BGRA8) {
    channels = 4;
    code = cv::COLOR_BGRA2GRAY;
  } else if (msg.encoding == enc::RGBA8) {
    channels = 4;
    code = cv::COLOR_RGBA2GRAY;
  } else {
    return std::string(which) + " image has unsupported encoding '" + msg.encoding +
           "' (need an 8-bit rectified image: mono8, bgr8, rgb8, bgra8 or rgba8)";
  }
  if (msg.width == 0 || msg.height == 0) return std::string(which) + " image is empty";
  const std::size_t row_bytes = static_cast<std::size_t>(msg.width) * channels;
  if (msg.step < row_bytes) {
    return std::string(which) + " image step " + std::to_string(msg.step) +
           " is smaller than width x channels = " + std::to_string(row_bytes);
  }
  const std::size_t needed = static_cast<std::size_t>(msg.step) * (msg.height - 1) + row_bytes;
  if (msg.data.size() < needed) {
    return std::string(which) + " image data has " + std::to_string(msg.data.size()) + " bytes, " +
           std::to_string(needed) + " needed for " + str(msg.width) + "x" + str(msg.height) + " " +
           msg.encoding + " with step " + std::to_string(msg.step);
  }
  // A view onto the message (read only: the pipeline does not write its inputs).
  const cv::Mat view(static_cast<int>(msg.height), static_cast<int>(msg.width), CV_8UC(channels),
                     const_cast<std::uint8_t*>(msg.data.data()), msg.step);
  if (channels == 1) {
    *grey = view;
  } else {
    cv::cvtColor(view, *buffer, code);
    *grey = *buffer;
  }
  return "";
}

nav_msgs::MapMetaData mapMetaData(const SafetyMap& map, const ros::Time& load_time) {
  nav_msgs::MapMetaData info;
  info.map_load_time = load_time;
  info.resolution = static_cast<float>(map.resolution);
  info.width = static_cast<std::uint32_t>(std::max(map.width, 0));
  info.height = static_cast<std::uint32_t>(std::max(map.height, 0));
  info.origin.position.x = (map.min_u - 0.5) * map.resolution;
  info.origin.position.y = (map.min_v - 0.5) * map.resolution;
  info.origin.position.z = 0.0;
  info.origin.orientation.w = 1.0;
  return info;
}

void toOccupancyGrid(const SafetyMap& map, const SafetyLabellingConfig& labelling,
                     const CostTable& costs, const std_msgs::Header& header,
                     nav_msgs::OccupancyGrid* out) {
  out->header = header;
  out->info = mapMetaData(map, header.stamp);
  safetyMapCosts(map, costs, labelling.level_slope_deg, labelling.max_slope_deg, &out->data);
}

void toSafetyMapMsg(const SafetyMap& map, const Eigen::Vector3f& robot_position,
                    const std_msgs::Header& header, SafetyMapMsg* out) {
  out->header = header;
  out->info = mapMetaData(map, header.stamp);
  out->labels.resize(map.labels.size());
  for (std::size_t i = 0; i < map.labels.size(); ++i) {
    out->labels[i] = static_cast<std::uint8_t>(map.labels[i]);
  }
  out->drop_off = map.drop_off;
  out->segment = map.segment;
  out->segments.resize(map.segments.size());
  for (std::size_t k = 0; k < map.segments.size(); ++k) {
    const SegmentInfo& s = map.segments[k];
    GroundSegment& g = out->segments[k];
    g.id = s.id;
    g.label = static_cast<std::uint8_t>(s.label);
    g.reachable = s.reachable;
    g.indexed_height = s.indexed_height;
    g.plane_valid = s.plane.valid;
    g.a = s.plane.a;
    g.b = s.plane.b;
    g.c = s.plane.c;
    g.normal.x = s.plane.normal.x();
    g.normal.y = s.plane.normal.y();
    g.normal.z = s.plane.normal.z();
    g.slope_deg = s.plane.slope_deg;
    g.residual_rms = s.plane.residual_rms;
    g.num_cells = static_cast<std::uint32_t>(s.cells.size());
    g.num_interior_cells = static_cast<std::uint32_t>(std::max(s.num_interior, 0));
    g.num_points = static_cast<std::uint32_t>(s.plane.num_points);
    g.centroid.x = s.plane.centroid.x();
    g.centroid.y = s.plane.centroid.y();
    g.centroid.z = s.plane.centroid.z();
  }
  out->robot_position.x = robot_position.x();
  out->robot_position.y = robot_position.y();
  out->robot_position.z = robot_position.z();
  out->robot_segment = map.robot_segment;
}

std_msgs::ColorRGBA colorMsg(float r, float g, float b, float a) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

geometry_msgs::Point pointMsg(double x, double y, double z) {
  geometry_msgs::Point p;
  p.x = x;
  p.y = y;
  p.z = z;
  return p;
}

void toMarkerArray(const SafetyMapper& mapper, const std_msgs::Header& header,
                   visualization_msgs::MarkerArray* out) {
  out->markers.clear();
  visualization_msgs::Marker clear;
  clear.header = header;
  clear.action = visualization_msgs::Marker::DELETEALL;
  out->markers.push_back(clear);

  const SafetyMap& map = mapper.safetyMap();
  const VoxelGrid& grid = mapper.grid();
  const double l = map.resolution;
  if (map.width <= 0 || map.height <= 0) return;

  // Fig. 4(b) colours: Level green, Inclined yellow, unreachable / too steep ground red.
  const std_msgs::ColorRGBA kLevel = colorMsg(0.1f, 0.8f, 0.1f, 0.8f);
  const std_msgs::ColorRGBA kInclined = colorMsg(0.95f, 0.85f, 0.1f, 0.8f);
  const std_msgs::ColorRGBA kUnreachable = colorMsg(0.85f, 0.1f, 0.1f, 0.8f);
  const std_msgs::ColorRGBA kVoxel = colorMsg(0.55f, 0.55f, 0.55f, 0.9f);

  for (const SegmentInfo& s : map.segments) {
    const std_msgs::ColorRGBA* color = nullptr;
    const char* name = "";
    switch (s.label) {
      case SafetyLabel::kLevel:
        color = &kLevel;
        name = "Level";
        break;
      case SafetyLabel::kInclined:
        color = &kInclined;
        name = "Inclined";
        break;
      case SafetyLabel::kNonGround:
        color = &kUnreachable;
        name = "Non-ground";
        break;
      default:
        break;
    }
    if (color == nullptr || s.cells.empty()) continue;
    visualization_msgs::Marker m;
    m.header = header;
    m.ns = "ground_planes";
    m.id = s.id;
    m.type = visualization_msgs::Marker::TRIANGLE_LIST;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.orientation.w = 1.0;
    m.scale.x = m.scale.y = m.scale.z = 1.0;
    m.color = *color;
    m.points.reserve(s.cells.size() * 6);
    // A segment without a valid plane is drawn flat at its indexed height (Eq. (1)).
    auto z_at = [&](double x, double y) {
      return s.plane.valid ? s.plane.heightAt(x, y) : s.indexed_height * l;
    };
    for (int cell : s.cells) {
      const int u = map.min_u + cell % map.width;
      const int v = map.min_v + cell / map.width;
      const double x0 = (u - 0.5) * l, x1 = (u + 0.5) * l;
      const double y0 = (v - 0.5) * l, y1 = (v + 0.5) * l;
      const geometry_msgs::Point p00 = pointMsg(x0, y0, z_at(x0, y0));
      const geometry_msgs::Point p10 = pointMsg(x1, y0, z_at(x1, y0));
      const geometry_msgs::Point p11 = pointMsg(x1, y1, z_at(x1, y1));
      const geometry_msgs::Point p01 = pointMsg(x0, y1, z_at(x0, y1));
      m.points.insert(m.points.end(), {p00, p10, p11, p00, p11, p01});
    }
    out->markers.push_back(m);

    if (s.plane.valid) {
      visualization_msgs::Marker t;
      t.header = header;
      t.ns = "slopes";
      t.id = s.id;
      t.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
      t.action = visualization_msgs::Marker::ADD;
      t.pose.position =
          pointMsg(s.plane.centroid.x(), s.plane.centroid.y(), s.plane.centroid.z() + 0.15);
      t.pose.orientation.w = 1.0;
      t.scale.z = 0.15;
      t.color = colorMsg(1.0f, 1.0f, 1.0f, 1.0f);
      char text[64];
      std::snprintf(text, sizeof(text), "%s %.1f deg", name, s.plane.slope_deg);
      t.text = text;
      out->markers.push_back(t);
    }
  }

  // Non-ground cells as the occupied voxels of their columns up to the robot's height.
  visualization_msgs::Marker cubes;
  cubes.header = header;
  cubes.ns = "non_ground_voxels";
  cubes.id = 0;
  cubes.type = visualization_msgs::Marker::CUBE_LIST;
  cubes.action = visualization_msgs::Marker::ADD;
  cubes.pose.orientation.w = 1.0;
  cubes.scale.x = cubes.scale.y = cubes.scale.z = l * 0.95;
  cubes.color = kVoxel;
  const VoxelIndex gmin = grid.minIndex();
  const int w_top = std::min(gmin.w + grid.sizeW() - 1, mapper.heightMap().topIndex());
  for (int v = map.min_v; v < map.min_v + map.height; ++v) {
    for (int u = map.min_u; u < map.min_u + map.width; ++u) {
      if (map.labelAt(u, v) != SafetyLabel::kNonGround) continue;
      const int s = map.segment[map.index(u, v)];
      if (s >= 0) continue;  // drawn as a (red) plane above
      for (int w = gmin.w; w <= w_top; ++w) {
        const VoxelIndex i{u, v, w};
        if (grid.isOccupied(i)) {
          const Eigen::Vector3f c = grid.centerOf(i);
          cubes.points.push_back(pointMsg(c.x(), c.y(), c.z()));
        }
      }
    }
  }
  if (!cubes.points.empty()) out->markers.push_back(cubes);

  visualization_msgs::Marker drop_offs;
  if (dropOffEdgeMarker(map, header, &drop_offs)) out->markers.push_back(drop_offs);
}

bool dropOffEdgeMarker(const SafetyMap& map, const std_msgs::Header& header,
                       visualization_msgs::Marker* out) {
  const std::size_t n = static_cast<std::size_t>(std::max(map.width, 0)) *
                        static_cast<std::size_t>(std::max(map.height, 0));
  if (n == 0 || map.drop_off.size() != n) return false;
  const double l = map.resolution;
  *out = visualization_msgs::Marker();
  out->header = header;
  out->ns = "drop_off_edges";
  out->id = 0;
  out->type = visualization_msgs::Marker::CUBE_LIST;
  out->action = visualization_msgs::Marker::ADD;
  out->pose.orientation.w = 1.0;
  out->scale.x = out->scale.y = l * 0.9;
  out->scale.z = 0.04;
  out->color = colorMsg(1.0f, 0.0f, 1.0f, 0.95f);  // magenta: no other label's colour
  for (int v = map.min_v; v < map.min_v + map.height; ++v) {
    for (int u = map.min_u; u < map.min_u + map.width; ++u) {
      const std::size_t k = static_cast<std::size_t>(map.index(u, v));
      if (map.drop_off[k] == 0) continue;
      const double x = u * l, y = v * l;
      double z = 0.0;
      const int s = k < map.segment.size() ? map.segment[k] : -1;
      const auto seg = std::find_if(map.segments.begin(), map.segments.end(),
                                    [s](const SegmentInfo& si) { return si.id == s; });
      if (s >= 0 && seg != map.segments.end()) {
        z = seg->plane.valid ? seg->plane.heightAt(x, y) : seg->indexed_height * l;
      } else if (k < map.column_height.size() && map.column_height[k] != SafetyMap::kNoHeight) {
        z = map.column_height[k] * l;
      }
      out->points.push_back(pointMsg(x, y, z + 0.02));
    }
  }
  return !out->points.empty();
}

void occupiedPointsToCloud(const VoxelGrid& grid, const std_msgs::Header& header,
                           sensor_msgs::PointCloud2* out) {
  out->header = header;
  sensor_msgs::PointCloud2Modifier modifier(*out);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  const VoxelIndex gmin = grid.minIndex();
  auto for_each_occupied = [&grid, &gmin](const auto& f) {
    for (int w = gmin.w; w < gmin.w + grid.sizeW(); ++w) {
      for (int v = gmin.v; v < gmin.v + grid.sizeV(); ++v) {
        for (int u = gmin.u; u < gmin.u + grid.sizeU(); ++u) {
          const VoxelIndex i{u, v, w};
          if (grid.isOccupied(i)) f(grid.points(i));
        }
      }
    }
  };
  std::size_t count = 0;
  for_each_occupied([&count](const VoxelPointList& list) { count += list.size; });
  modifier.resize(count);
  out->height = 1;
  out->width = static_cast<std::uint32_t>(count);
  out->row_step = out->width * out->point_step;
  out->is_dense = true;
  // An iterator over an empty cloud reads data.front() of an empty vector (UBSan found it).
  if (count == 0) return;
  sensor_msgs::PointCloud2Iterator<float> x(*out, "x"), y(*out, "y"), z(*out, "z");
  for_each_occupied([&x, &y, &z](const VoxelPointList& list) {
    for (const VoxelPoint& p : list) {
      *x = p.position.x();
      *y = p.position.y();
      *z = p.position.z();
      ++x;
      ++y;
      ++z;
    }
  });
}

void toStageTimingsMsg(const StageTimings& timings, const std_msgs::Header& header,
                       StageTimingsMsg* out) {
  out->header = header;
  out->integrate_ms = timings.integrate_ms;
  out->height_map_ms = timings.height_map_ms;
  out->segmentation_ms = timings.segmentation_ms;
  out->plane_fit_ms = timings.plane_fit_ms;
  out->labelling_ms = timings.labelling_ms;
  out->total_ms = timings.total_ms;
}

}  // namespace stereo_safety_map
