// Floor seen under an overhang (overhang_roof.h): small voxel worlds whose answer is known. A
// camera 1.2 m above the floor at the origin looks along +x; a table top 0.8 m high spans
// x = 2.0 .. 2.8 m and stereo saw only its front and back edges, with the rays to the floor
// under it having cleared the voxels below them.
#include "stereo_safety_map/core/overhang_roof.h"

#include <gtest/gtest.h>

#include <limits>

namespace stereo_safety_map {
namespace {

constexpr int kOccupied = 200;
constexpr int kFree = -20;

VoxelGridConfig roomGrid() {
  VoxelGridConfig c;
  c.size_x = 8.0;
  c.size_y = 4.0;
  c.size_z = 3.0;
  c.z_below_robot = 1.0;
  return c;
}

struct World {
  VoxelGrid grid{roomGrid()};
  HeightMap hm;
  SafetyMap map;
  OverhangRoofConfig config;
  OverhangRoofScratch scratch;
  Eigen::Vector3f camera{0.0f, 0.0f, 1.2f};

  World() {
    grid.recenter(Eigen::Vector3f(2.0f, 0.0f, 0.0f));
    // The floor (w = 0) everywhere, seen.
    const VoxelIndex lo = grid.minIndex();
    for (int v = lo.v; v < lo.v + grid.sizeV(); ++v)
      for (int u = lo.u; u < lo.u + grid.sizeU(); ++u)
        grid.setLogOdds({u, v, 0}, kOccupied);
  }
  // A roof column: top at w, the voxels from 2 to w - 1 observed free.
  void roofColumn(int u, int v, int w) {
    grid.setLogOdds({u, v, w}, kOccupied);
    for (int k = 2; k < w; ++k)
      grid.setLogOdds({u, v, k}, kFree);
  }
  // A solid column (a pole, a wall): occupied from the floor up to w.
  void solidColumn(int u, int v, int w) {
    for (int k = 1; k <= w; ++k)
      grid.setLogOdds({u, v, k}, kOccupied);
  }
  // The table top's edges at x = 2.0 and 2.8 m, y = -0.3 .. 0.3 m, 0.8 m high.
  void tableEdges() {
    for (int v = -3; v <= 3; ++v) {
      roofColumn(20, v, 8);
      roofColumn(28, v, 8);
    }
  }
  // Labels every column Level, then runs the rule; `after_build` may change the heights first.
  template <class AfterBuild = void (*)(HeightMap&)>
  int run(AfterBuild after_build = [](HeightMap&) {}) {
    EXPECT_TRUE(hm.build(grid, 0.0f));
    after_build(hm);
    map = SafetyMap();
    map.min_u = hm.minU();
    map.min_v = hm.minV();
    map.width = hm.width();
    map.height = hm.height();
    map.resolution = 0.1;
    map.labels.assign(hm.numCells(), SafetyLabel::kLevel);
    map.drop_off.assign(hm.numCells(), 0);
    map.segment.assign(hm.numCells(), 0);
    return markFloorUnderOverhangs(grid, hm, camera, 0.0f, config, &map, &scratch);
  }
  SafetyLabel at(int u, int v) const { return map.labels[map.index(u, v)]; }
};

TEST(OverhangRoofConfig, Validate) {
  OverhangRoofConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_TRUE(c.enabled);
  c.max_span = 0.0;
  EXPECT_NE(c.validate().find("overhang_roof_max_span"), std::string::npos);
  c = OverhangRoofConfig();
  c.min_clearance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(c.validate().find("overhang_roof_min_clearance"), std::string::npos);
  c = OverhangRoofConfig();
  c.min_free_voxels = 0;
  EXPECT_NE(c.validate().find("overhang_roof_min_free_voxels"), std::string::npos);
}

TEST(OverhangRoof, TheFloorSeenUnderATableTopIsNonGround) {
  World w;
  w.tableEdges();
  const int marked = w.run();
  EXPECT_GT(marked, 0);
  // Each marked cell is listed with the edge column that roofs it (for the obstacle memory).
  ASSERT_EQ(static_cast<int>(w.scratch.marks.size()), marked);
  for (const OverhangRoofMark& r : w.scratch.marks) {
    EXPECT_EQ(w.map.labels[r.cell], SafetyLabel::kNonGround);
    EXPECT_TRUE(r.roof_u == 20 || r.roof_u == 28) << r.roof_u;
    EXPECT_EQ(r.roof_w, 8);
    EXPECT_LT(r.roof_u, w.map.min_u + r.cell % w.map.width);
  }
  // Under the top, on the camera's line of sight: Non-ground; and behind the last edge seen, up
  // to max_span (1 m) behind it: its depth is not known.
  for (int u = 21; u <= 27; ++u)
    EXPECT_EQ(w.at(u, 0), SafetyLabel::kNonGround) << "u " << u;
  for (int u = 29; u <= 37; ++u)
    EXPECT_EQ(w.at(u, 0), SafetyLabel::kNonGround) << "u " << u;
  // Before the front edge and farther behind: unchanged.
  for (int u = 10; u <= 19; ++u)
    EXPECT_EQ(w.at(u, 0), SafetyLabel::kLevel) << "u " << u;
  for (int u = 39; u <= 50; ++u)
    EXPECT_EQ(w.at(u, 0), SafetyLabel::kLevel) << "u " << u;
  // Beside the table, where no edge lies on the sight line: unchanged.
  EXPECT_EQ(w.at(24, 8), SafetyLabel::kLevel);
  EXPECT_EQ(w.at(24, -8), SafetyLabel::kLevel);
}

// With mass_bands a column's indexed height is the voxel its points' mean lies in, which for a
// thick top can be below its highest occupied voxel: the mark keeps the occupied top, the voxel
// the obstacle memory watches.
TEST(OverhangRoof, AMarkKeepsTheRoofsHighestOccupiedVoxel) {
  World w;
  w.tableEdges();
  for (int v = -3; v <= 3; ++v) {
    w.grid.setLogOdds({20, v, 9}, kOccupied);  // a top two voxels thick
    w.grid.setLogOdds({28, v, 9}, kOccupied);
  }
  const int marked = w.run([](HeightMap& hm) {
    for (int v = -3; v <= 3; ++v) {
      hm.set(20, v, 8, 0);  // as mass_bands would index the column: its points' mean in w = 8
      hm.set(28, v, 8, 0);
    }
  });
  ASSERT_GT(marked, 0);
  for (const OverhangRoofMark& r : w.scratch.marks)
    EXPECT_EQ(r.roof_w, 9) << "roof column " << r.roof_u << ", " << r.roof_v;
}

TEST(OverhangRoof, TheFloorUnderAShelfSeenAtItsFrontEdge) {
  World w;
  // A board 0.8 m high from x = 3.0 m, seen at its front edge only, on a wall at x = 3.4 m.
  for (int v = -5; v <= 5; ++v) {
    w.roofColumn(30, v, 8);
    w.solidColumn(34, v, 20);
  }
  w.run();
  for (int u = 31; u <= 33; ++u)
    EXPECT_EQ(w.at(u, 0), SafetyLabel::kNonGround) << "u " << u;
  EXPECT_EQ(w.at(29, 0), SafetyLabel::kLevel);
}

TEST(OverhangRoof, TwoPolesAreNoRoof) {
  World w;
  // Solid columns as high as the table's edges: their voxels below the top are occupied.
  for (int v = -3; v <= 3; ++v) {
    w.solidColumn(20, v, 8);
    w.solidColumn(28, v, 8);
  }
  EXPECT_EQ(w.run(), 0);
  EXPECT_EQ(w.at(24, 0), SafetyLabel::kLevel);
}

TEST(OverhangRoof, ATopSeenOverIsNoRoof) {
  World w;
  // The same table top at 0.3 m: the sight line to the floor behind its front edge passes
  // above it (and a 0.3 m top has no free voxel below it above the floor band).
  for (int v = -3; v <= 3; ++v) {
    w.roofColumn(20, v, 3);
    w.roofColumn(28, v, 3);
  }
  EXPECT_EQ(w.run(), 0);
}

TEST(OverhangRoof, UnreachedVoxelsBelowATopAreNoRoof) {
  World w;
  // Tops with nothing observed below them (a box's lid: no ray passes under it).
  for (int v = -3; v <= 3; ++v) {
    w.grid.setLogOdds({20, v, 8}, kOccupied);
    w.grid.setLogOdds({28, v, 8}, kOccupied);
  }
  EXPECT_EQ(w.run(), 0);
}

TEST(OverhangRoof, OffOrWithoutACameraChangesNothing) {
  World w;
  w.tableEdges();
  w.config.enabled = false;
  EXPECT_EQ(w.run(), 0);
  w.config.enabled = true;
  EXPECT_GT(w.run(), 0);
  EXPECT_FALSE(w.scratch.marks.empty());
  w.camera = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  EXPECT_EQ(w.run(), 0);
  EXPECT_TRUE(w.scratch.marks.empty());  // the last call's marks only
  EXPECT_EQ(w.at(24, 0), SafetyLabel::kLevel);
}

}  // namespace
}  // namespace stereo_safety_map
