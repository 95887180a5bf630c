// fromSafetyMapMsg (ros/safety_map_msg_conversions.h): a core map through toSafetyMapMsg and back
// keeps its grid, labels, drop-off edges, segments and planes; malformed messages are refused
// with the field's name.
#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/safety_map_msg_conversions.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace stereo_safety_map;

namespace {

SafetyMap sampleMap() {
  SafetyMap m;
  m.min_u = -12;
  m.min_v = 7;
  m.width = 5;
  m.height = 4;
  m.resolution = 0.1;
  m.robot_u = -10;
  m.robot_v = 8;
  const int n = m.width * m.height;
  m.labels.assign(n, SafetyLabel::kLevel);
  m.drop_off.assign(n, 0);
  m.segment.assign(n, 0);
  SegmentInfo level;
  level.id = 0;
  level.label = SafetyLabel::kLevel;
  level.reachable = true;
  level.plane.valid = true;
  level.plane.c = 0.01;
  SegmentInfo ramp;
  ramp.id = 1;
  ramp.label = SafetyLabel::kInclined;
  ramp.reachable = true;
  ramp.plane.valid = true;
  ramp.plane.a = std::tan(6.0 * M_PI / 180.0);
  ramp.plane.slope_deg = 6.0;
  m.segments = {level, ramp};
  for (int v = 0; v < m.height; ++v) {
    m.labels[v * m.width + 4] = SafetyLabel::kInclined;
    m.segment[v * m.width + 4] = 1;
    m.labels[v * m.width + 3] = SafetyLabel::kUnknown;
    m.segment[v * m.width + 3] = -1;
  }
  m.drop_off[2] = 1;
  m.labels[7] = SafetyLabel::kNonGround;
  m.segment[7] = -1;
  m.robot_segment = 0;
  for (int k = 0; k < n; ++k) {
    if (m.segment[k] >= 0) m.segments[m.segment[k]].cells.push_back(k);
  }
  return m;
}

SafetyMapMsg toMsg(const SafetyMap& m) {
  SafetyMapMsg msg;
  std_msgs::Header h;
  h.frame_id = "odom";
  toSafetyMapMsg(m, Eigen::Vector3f(-1.0f, 0.8f, 0.0f), h, &msg);
  return msg;
}

TEST(FromSafetyMapMsg, RoundTripKeepsGridLabelsSegmentsAndPlanes) {
  const SafetyMap m = sampleMap();
  SafetyMap back;
  ASSERT_EQ(fromSafetyMapMsg(toMsg(m), &back), "");
  EXPECT_EQ(back.min_u, m.min_u);
  EXPECT_EQ(back.min_v, m.min_v);
  EXPECT_EQ(back.width, m.width);
  EXPECT_EQ(back.height, m.height);
  EXPECT_NEAR(back.resolution, m.resolution, 1e-6);
  EXPECT_EQ(back.labels, m.labels);
  EXPECT_EQ(back.drop_off, m.drop_off);
  EXPECT_EQ(back.segment, m.segment);
  ASSERT_EQ(back.segments.size(), 2u);
  EXPECT_EQ(back.segments[1].label, SafetyLabel::kInclined);
  EXPECT_TRUE(back.segments[1].plane.valid);
  EXPECT_DOUBLE_EQ(back.segments[1].plane.slope_deg, 6.0);
  EXPECT_EQ(back.segments[1].cells, m.segments[1].cells);
  EXPECT_EQ(back.robot_u, -10);
  EXPECT_EQ(back.robot_v, 8);
  EXPECT_EQ(back.robot_segment, 0);
}

TEST(FromSafetyMapMsg, RefusesMalformedMessagesNamingTheField) {
  SafetyMap out;
  SafetyMapMsg msg = toMsg(sampleMap());
  msg.segment.pop_back();
  EXPECT_NE(fromSafetyMapMsg(msg, &out).find("segment has"), std::string::npos);
  msg = toMsg(sampleMap());
  msg.segment[3] = 7;
  EXPECT_NE(fromSafetyMapMsg(msg, &out).find("segment[3]"), std::string::npos);
  msg = toMsg(sampleMap());
  msg.segments[1].label = 9;
  EXPECT_NE(fromSafetyMapMsg(msg, &out).find("segments[1].label"), std::string::npos);
  msg = toMsg(sampleMap());
  msg.segments[1].slope_deg = std::nan("");
  EXPECT_NE(fromSafetyMapMsg(msg, &out).find("segments[1]"), std::string::npos);
  msg = toMsg(sampleMap());
  msg.labels[0] = 5;
  EXPECT_NE(fromSafetyMapMsg(msg, &out).find("labels[0]"), std::string::npos);
  msg = toMsg(sampleMap());
  msg.info.resolution = 0.0f;
  EXPECT_NE(fromSafetyMapMsg(msg, &out).find("resolution"), std::string::npos);
  // An empty segment array: no segments per cell (the labels still count).
  msg = toMsg(sampleMap());
  msg.segment.clear();
  ASSERT_EQ(fromSafetyMapMsg(msg, &out), "");
  EXPECT_EQ(out.segment, std::vector<std::int32_t>(20, -1));
}

}  // namespace

// rviz: the drop-off edges get a marker of their own (the OccupancyGrid gives them Non-ground's
// cost), exactly one tile per drop-off cell, on the cell's segment plane.
TEST(DropOffEdgeMarker, OneTilePerDropOffCellOnItsPlane) {
  SafetyMap m = sampleMap();
  m.drop_off[9] = 1;  // on the ramp (column 4, row 1): plane z = tan(6 deg) x
  std_msgs::Header h;
  h.frame_id = "odom";
  visualization_msgs::Marker marker;
  ASSERT_TRUE(dropOffEdgeMarker(m, h, &marker));
  EXPECT_EQ(marker.ns, "drop_off_edges");
  EXPECT_EQ(marker.type, visualization_msgs::Marker::CUBE_LIST);
  EXPECT_EQ(marker.header.frame_id, "odom");
  ASSERT_EQ(marker.points.size(), 2u);
  // Cell 2: (u, v) = (-10, 7) on the level plane z = 0.01.
  EXPECT_NEAR(marker.points[0].x, -1.0, 1e-9);
  EXPECT_NEAR(marker.points[0].y, 0.7, 1e-9);
  EXPECT_NEAR(marker.points[0].z, 0.01 + 0.02, 1e-9);
  // Cell 9: (u, v) = (-8, 8) on the ramp.
  EXPECT_NEAR(marker.points[1].x, -0.8, 1e-9);
  EXPECT_NEAR(marker.points[1].y, 0.8, 1e-9);
  EXPECT_NEAR(marker.points[1].z, std::tan(6.0 * M_PI / 180.0) * -0.8 + 0.02, 1e-9);
  // Not Non-ground's colour or any label's: magenta.
  EXPECT_EQ(marker.color.r, 1.0f);
  EXPECT_EQ(marker.color.g, 0.0f);
  EXPECT_EQ(marker.color.b, 1.0f);

  std::fill(m.drop_off.begin(), m.drop_off.end(), 0);
  EXPECT_FALSE(dropOffEdgeMarker(m, h, &marker));
}
