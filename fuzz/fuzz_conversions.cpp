// libFuzzer target: the ROS message -> core conversions (include/stereo_safety_map/ros/
// conversions.h). Message classes are plain C++ structs, so no roscore or node is needed.
//
// Inputs: CameraInfo pairs (zero / NaN / huge K and P, odd distortion models and D sizes,
// binning, regions of interest), DisparityImage (encodings, byte order, wrong and absurd steps,
// widths and heights, short or long data, NaN / inf pixels, odd disparity ranges) and PointCloud2
// (missing, duplicated, mistyped fields, offsets outside the point, wrong point_step / row_step,
// absurd sizes, short data, NaN / inf points).
//
// Also rectified 8-bit images (rectifiedImageToGrey: encodings, steps, sizes, short data).
//
// Contracts checked (conversions.h): nothing throws; on success the outputs are consistent
// (image size and type, only finite valid pixels, one finite point per finite input point, a
// camera model that validates, a grey image of the message's size); on failure the reason is
// not empty; the callback checks (checkDisparityImage, checkPointCloud2) accept exactly what the
// conversions accept and count the same invalid values.
#include "fuzz_common.h"

#include "stereo_safety_map/ros/conversions.h"

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/PointField.h>
#include <stereo_msgs/DisparityImage.h>

#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

using namespace stereo_safety_map;
using ssm_fuzz::mostlyInRange;
using ssm_fuzz::specialDouble;
using ssm_fuzz::specialFloat;

namespace {

// The harness's budget for message data actually allocated (sizes in the fields are unbounded).
constexpr std::size_t kMaxDataBytes = 1 << 18;

std::uint32_t randomDimension(FuzzedDataProvider& fdp, std::uint32_t typical_max) {
  switch (fdp.ConsumeIntegralInRange<int>(0, 15)) {
    case 0:
      return 0;
    case 1:
      return std::numeric_limits<std::uint32_t>::max();
    case 2:
      return fdp.ConsumeIntegral<std::uint32_t>();
    case 3:
      return 1u << fdp.ConsumeIntegralInRange<int>(16, 31);
    default:
      return fdp.ConsumeIntegralInRange<std::uint32_t>(1, typical_max);
  }
}

std::string randomString(FuzzedDataProvider& fdp, const std::vector<std::string>& usual) {
  if (fdp.ConsumeIntegralInRange<int>(0, 7) == 0) return fdp.ConsumeRandomLengthString(12);
  return usual[fdp.ConsumeIntegralInRange<std::size_t>(0, usual.size() - 1)];
}

// Fills `data` with `n` bytes (capped), floats from the fuzzer where they fit.
void fillData(FuzzedDataProvider& fdp, std::size_t n, std::vector<std::uint8_t>* data) {
  data->assign(std::min(n, kMaxDataBytes), 0);
  const int special_one_in = fdp.ConsumeIntegralInRange<int>(2, 32);
  for (std::size_t i = 0; i + sizeof(float) <= data->size(); i += sizeof(float)) {
    if (fdp.remaining_bytes() == 0) break;
    float v = fdp.ConsumeIntegralInRange<int>(1, special_one_in) == 1
                  ? specialFloat(fdp, -10.0f, 64.0f)
                  : static_cast<float>(fdp.ConsumeIntegralInRange<int>(-8, 255)) * 0.25f;
    std::memcpy(data->data() + i, &v, sizeof(float));
  }
}

sensor_msgs::CameraInfo randomCameraInfo(FuzzedDataProvider& fdp, bool right, double fx,
                                         double baseline, std::uint32_t width,
                                         std::uint32_t height) {
  sensor_msgs::CameraInfo info;
  // Drivers name the two optical frames alike or not; image_geometry wants them equal.
  info.header.frame_id = fdp.ConsumeIntegralInRange<int>(0, 7) == 0
                             ? (right ? "right_optical" : "left_optical")
                             : "stereo_optical";
  info.width = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? randomDimension(fdp, 64) : width;
  info.height = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? randomDimension(fdp, 48) : height;
  info.distortion_model =
      randomString(fdp, {"plumb_bob", "plumb_bob", "rational_polynomial", "equidistant", ""});
  const int nd =
      fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? fdp.ConsumeIntegralInRange<int>(0, 14) : 5;
  for (int i = 0; i < nd; ++i)
    info.D.push_back(mostlyInRange(fdp, -0.1, 0.1));
  const double cx = mostlyInRange(fdp, 0.0, width, 16);
  const double cy = mostlyInRange(fdp, 0.0, height, 16);
  const double fy = fdp.ConsumeBool() ? fx : mostlyInRange(fdp, 10.0, 600.0, 16);
  info.K = {fx, 0, cx, 0, fy, cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {fx, 0, cx, right ? -fx * baseline : 0.0, 0, fy, cy, 0, 0, 0, 1, 0};
  // A few entries anything.
  const int wild = fdp.ConsumeIntegralInRange<int>(0, 3);
  for (int i = 0; i < wild; ++i) {
    const int which = fdp.ConsumeIntegralInRange<int>(0, 2);
    const double v = specialDouble(fdp, -1000.0, 1000.0);
    if (which == 0) info.K[fdp.ConsumeIntegralInRange<int>(0, 8)] = v;
    if (which == 1) info.R[fdp.ConsumeIntegralInRange<int>(0, 8)] = v;
    if (which == 2) info.P[fdp.ConsumeIntegralInRange<int>(0, 11)] = v;
  }
  if (fdp.ConsumeIntegralInRange<int>(0, 3) == 0) {
    info.binning_x = fdp.ConsumeIntegralInRange<int>(0, 3) == 0
                         ? fdp.ConsumeIntegral<std::uint32_t>()
                         : fdp.ConsumeIntegralInRange<std::uint32_t>(0, 4);
    info.binning_y = fdp.ConsumeIntegralInRange<int>(0, 3) == 0
                         ? fdp.ConsumeIntegral<std::uint32_t>()
                         : fdp.ConsumeIntegralInRange<std::uint32_t>(0, 4);
  }
  if (fdp.ConsumeIntegralInRange<int>(0, 3) == 0) {
    info.roi.x_offset = randomDimension(fdp, 32);
    info.roi.y_offset = randomDimension(fdp, 32);
    info.roi.width = randomDimension(fdp, 64);
    info.roi.height = randomDimension(fdp, 48);
    info.roi.do_rectify = fdp.ConsumeBool();
  }
  return info;
}

void checkModel(const std::string& err, const StereoCameraModel& model) {
  if (err.empty()) FUZZ_CHECK(model.validate().empty());
}

void fuzzCameraInfo(FuzzedDataProvider& fdp) {
  const double fx = mostlyInRange(fdp, 10.0, 600.0, 8);
  const double baseline = mostlyInRange(fdp, 0.01, 0.5, 8);
  const std::uint32_t width = fdp.ConsumeIntegralInRange<std::uint32_t>(1, 64);
  const std::uint32_t height = fdp.ConsumeIntegralInRange<std::uint32_t>(1, 48);
  const sensor_msgs::CameraInfo left = randomCameraInfo(fdp, false, fx, baseline, width, height);
  const sensor_msgs::CameraInfo right = randomCameraInfo(fdp, true, fx, baseline, width, height);
  StereoCameraModel model;
  checkModel(cameraModelFromCameraInfo(left, right, &model), model);

  stereo_msgs::DisparityImage disparity;
  disparity.f = fdp.ConsumeBool() ? static_cast<float>(fx) : specialFloat(fdp, 1.0f, 600.0f);
  disparity.T = fdp.ConsumeBool() ? static_cast<float>(baseline) : specialFloat(fdp, 0.0f, 0.5f);
  disparity.image.width = fdp.ConsumeBool() ? width : randomDimension(fdp, 64);
  disparity.image.height = fdp.ConsumeBool() ? height : randomDimension(fdp, 48);
  StereoCameraModel model2;
  checkModel(cameraModelForDisparity(disparity, left, &model2), model2);
}

void fuzzDisparityImage(FuzzedDataProvider& fdp) {
  stereo_msgs::DisparityImage msg;
  sensor_msgs::Image& img = msg.image;
  img.encoding = randomString(fdp, {"32FC1", "32FC1", "32FC1", "mono8", "16UC1", "32FC2", ""});
  img.is_bigendian =
      fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? fdp.ConsumeIntegral<std::uint8_t>() : 0;
  img.width = randomDimension(fdp, 48);
  img.height = randomDimension(fdp, 32);
  // Step: exact, padded, short, not a multiple of 4, or anything.
  const std::uint32_t exact = img.width * 4u;  // wraps for absurd widths, on purpose
  switch (fdp.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      img.step = exact - fdp.ConsumeIntegralInRange<std::uint32_t>(1, 4);
      break;
    case 1:
      img.step = exact + fdp.ConsumeIntegralInRange<std::uint32_t>(1, 3);
      break;
    case 2:
      img.step = fdp.ConsumeIntegral<std::uint32_t>();
      break;
    case 3:
      img.step = exact + 4u * fdp.ConsumeIntegralInRange<std::uint32_t>(1, 8);
      break;
    default:
      img.step = exact;
      break;
  }
  // Data: what step x height needs, or shorter, or longer (allocation capped).
  std::size_t needed = static_cast<std::size_t>(img.step) * img.height;
  switch (fdp.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      needed = needed > 0 ? needed - fdp.ConsumeIntegralInRange<std::size_t>(
                                         1, std::min<std::size_t>(needed, 8))
                          : 0;
      break;
    case 1:
      needed += fdp.ConsumeIntegralInRange<std::size_t>(1, 16);
      break;
    case 2:
      needed = fdp.ConsumeIntegralInRange<std::size_t>(0, 64);
      break;
    default:
      break;
  }
  fillData(fdp, needed, &img.data);
  msg.min_disparity = fdp.ConsumeBool() ? 0.0f : specialFloat(fdp, -2.0f, 10.0f);
  msg.max_disparity = fdp.ConsumeBool() ? 64.0f : specialFloat(fdp, -2.0f, 100.0f);

  msg.f = fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? specialFloat(fdp, 0.0f, 600.0f) : 250.0f;
  msg.T = fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? specialFloat(fdp, 0.0f, 0.5f) : 0.12f;

  cv::Mat out;
  if (fdp.ConsumeBool()) out.create(3, 5, CV_8UC3);  // a reused buffer of another kind
  DisparityImageStats stats;
  const bool want_stats = fdp.ConsumeBool();
  const std::string err = disparityImageToMat(msg, &out, want_stats ? &stats : nullptr);
  // The callback's check: the same verdict (f and T checked on top), the same counts.
  DisparityImageStats check_stats;
  const std::string check_err = checkDisparityImage(msg, &check_stats);
  const bool f_t_ok = std::isfinite(msg.f) && msg.f > 0.0f && std::isfinite(msg.T) && msg.T > 0.0f;
  FUZZ_CHECK(check_err.empty() == (err.empty() && f_t_ok));
  if (check_err.empty() && want_stats) {
    FUZZ_CHECK(check_stats.pixels == stats.pixels);
    FUZZ_CHECK(check_stats.non_finite == stats.non_finite);
    FUZZ_CHECK(check_stats.out_of_range == stats.out_of_range);
  }
  if (!err.empty()) return;
  FUZZ_CHECK(out.type() == CV_32FC1);
  FUZZ_CHECK(static_cast<std::uint32_t>(out.cols) == img.width &&
             static_cast<std::uint32_t>(out.rows) == img.height);
  FUZZ_CHECK(stats.non_finite + stats.out_of_range <= stats.pixels);
  for (int r = 0; r < out.rows; ++r) {
    for (int c = 0; c < out.cols; ++c)
      FUZZ_CHECK(std::isfinite(out.at<float>(r, c)));
  }
}

void fuzzPointCloud(FuzzedDataProvider& fdp) {
  sensor_msgs::PointCloud2 msg;
  msg.is_bigendian = fdp.ConsumeIntegralInRange<int>(0, 15) == 0;
  msg.is_dense = fdp.ConsumeBool();
  // Fields: usually x, y, z as FLOAT32 at 0, 4, 8 (+ rgb at 16), with mistakes mixed in.
  const char* names[] = {"x", "y", "z", "rgb", "intensity", "X", ""};
  const int num_fields =
      fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? fdp.ConsumeIntegralInRange<int>(0, 6) : 3;
  for (int i = 0; i < num_fields; ++i) {
    sensor_msgs::PointField f;
    f.name = (num_fields == 3 && fdp.ConsumeIntegralInRange<int>(0, 15) != 0)
                 ? names[i]
                 : names[fdp.ConsumeIntegralInRange<int>(0, 6)];
    f.offset = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? randomDimension(fdp, 32)
                                                           : static_cast<std::uint32_t>(4 * i);
    f.datatype = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? fdp.ConsumeIntegral<std::uint8_t>()
                                                             : sensor_msgs::PointField::FLOAT32;
    f.count =
        fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? fdp.ConsumeIntegral<std::uint32_t>() : 1;
    msg.fields.push_back(f);
  }
  msg.width = randomDimension(fdp, 40);
  msg.height = fdp.ConsumeBool() ? 1 : randomDimension(fdp, 8);
  switch (fdp.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      msg.point_step = fdp.ConsumeIntegral<std::uint32_t>();
      break;
    case 1:
      msg.point_step = fdp.ConsumeIntegralInRange<std::uint32_t>(0, 11);
      break;
    default:
      msg.point_step = fdp.ConsumeBool() ? 12 : 16;
      break;
  }
  const std::uint32_t exact_row = msg.width * msg.point_step;  // wraps on purpose
  switch (fdp.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      msg.row_step = fdp.ConsumeIntegral<std::uint32_t>();
      break;
    case 1:
      msg.row_step = exact_row - fdp.ConsumeIntegralInRange<std::uint32_t>(1, 4);
      break;
    case 2:
      msg.row_step = exact_row + fdp.ConsumeIntegralInRange<std::uint32_t>(1, 12);
      break;
    default:
      msg.row_step = exact_row;
      break;
  }
  std::size_t needed = static_cast<std::size_t>(msg.row_step) * msg.height;
  switch (fdp.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      needed = needed > 0 ? needed - 1 : 0;
      break;
    case 1:
      needed = fdp.ConsumeIntegralInRange<std::size_t>(0, 64);
      break;
    case 2:
      needed += fdp.ConsumeIntegralInRange<std::size_t>(1, 16);
      break;
    default:
      break;
  }
  fillData(fdp, needed, &msg.data);

  std::vector<Eigen::Vector3f> points;
  if (fdp.ConsumeBool()) points.assign(3, Eigen::Vector3f::Ones());  // reused, not empty
  CloudStats stats;
  const bool want_stats = fdp.ConsumeBool();
  const std::string err = pointCloud2ToPoints(msg, &points, want_stats ? &stats : nullptr);
  CloudStats check_stats;
  const std::string check_err = checkPointCloud2(msg, &check_stats);
  FUZZ_CHECK(check_err.empty() == err.empty());
  if (!err.empty()) {
    FUZZ_CHECK(points.empty());
    return;
  }
  FUZZ_CHECK(check_stats.points == static_cast<std::size_t>(msg.width) * msg.height);
  FUZZ_CHECK(points.size() + check_stats.non_finite == check_stats.points);
  for (const Eigen::Vector3f& p : points)
    FUZZ_CHECK(p.allFinite());
  if (want_stats) {
    FUZZ_CHECK(stats.points == static_cast<std::size_t>(msg.width) * msg.height);
    FUZZ_CHECK(points.size() + stats.non_finite == stats.points);
  }
}

void fuzzImage(FuzzedDataProvider& fdp) {
  sensor_msgs::Image img;
  img.encoding =
      randomString(fdp, {"mono8", "8UC1", "bgr8", "rgb8", "bgra8", "rgba8", "mono16", "32FC1", ""});
  img.is_bigendian = fdp.ConsumeBool();
  img.width = randomDimension(fdp, 40);
  img.height = randomDimension(fdp, 30);
  const std::uint32_t channels = fdp.ConsumeIntegralInRange<std::uint32_t>(1, 4);
  const std::uint32_t exact = img.width * channels;  // wraps on purpose
  switch (fdp.ConsumeIntegralInRange<int>(0, 5)) {
    case 0:
      img.step = fdp.ConsumeIntegral<std::uint32_t>();
      break;
    case 1:
      img.step = exact - fdp.ConsumeIntegralInRange<std::uint32_t>(1, 3);
      break;
    case 2:
      img.step = exact + fdp.ConsumeIntegralInRange<std::uint32_t>(1, 9);
      break;
    default:
      img.step = exact;
      break;
  }
  std::size_t needed = static_cast<std::size_t>(img.step) * img.height;
  if (fdp.ConsumeIntegralInRange<int>(0, 3) == 0) {
    needed = fdp.ConsumeIntegralInRange<std::size_t>(0, needed > 0 ? needed - 1 : 0);
  }
  img.data.assign(std::min(needed, kMaxDataBytes), 0);
  for (auto& b : img.data) {
    if (fdp.remaining_bytes() == 0) break;
    b = fdp.ConsumeIntegral<std::uint8_t>();
  }
  cv::Mat buffer, grey;
  if (fdp.ConsumeBool()) buffer.create(2, 3, CV_32FC2);  // a reused buffer of another kind
  const std::string err = rectifiedImageToGrey(img, "left", &buffer, &grey);
  if (!err.empty()) return;
  FUZZ_CHECK(grey.type() == CV_8UC1);
  FUZZ_CHECK(static_cast<std::uint32_t>(grey.cols) == img.width &&
             static_cast<std::uint32_t>(grey.rows) == img.height);
  volatile std::uint8_t sink = 0;
  for (int r = 0; r < grey.rows; ++r)
    sink = sink + grey.ptr<std::uint8_t>(r)[grey.cols - 1];
}

void fuzzSafetyCost(FuzzedDataProvider& fdp) {
  const auto label = static_cast<SafetyLabel>(fdp.ConsumeIntegral<std::uint8_t>());
  CostTable table;  // any valid table
  table.level = fdp.ConsumeIntegralInRange<int>(0, 20);
  table.inclined_low = fdp.ConsumeIntegralInRange<int>(table.level, 60);
  table.inclined_high = fdp.ConsumeIntegralInRange<int>(table.inclined_low, 99);
  table.drop_off = fdp.ConsumeIntegralInRange<int>(1, 100);
  FUZZ_CHECK(table.validate().empty());
  const bool drop = fdp.ConsumeBool();
  const std::int8_t cost = cellCost(table, label, drop, specialDouble(fdp, 0.0, 30.0),
                                    specialDouble(fdp, 0.0, 10.0), specialDouble(fdp, 5.0, 30.0));
  FUZZ_CHECK(cost >= -1 && cost <= 100);
  // Nothing hazardous is free: Non-ground lethal, a drop-off edge at its configured cost.
  if (label == SafetyLabel::kNonGround) FUZZ_CHECK(cost == 100);
  if (drop && isSafe(label)) FUZZ_CHECK(cost == table.drop_off);
  if (isSafe(label) && !drop) FUZZ_CHECK(cost <= 99);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider fdp(data, size);
  switch (fdp.ConsumeIntegralInRange<int>(0, 4)) {
    case 0:
      fuzzCameraInfo(fdp);
      break;
    case 3:
      fuzzImage(fdp);
      break;
    case 1:
      fuzzDisparityImage(fdp);
      break;
    case 2:
      fuzzPointCloud(fdp);
      break;
    default:
      fuzzSafetyCost(fdp);
      break;
  }
  return 0;
}
