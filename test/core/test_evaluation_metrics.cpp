// Evaluation metrics (000 Sec. VII-A, VII-B, VII-C; 001 Sec. 5) on hand-made map pairs whose
// counts, rates, angles, distances and coverages are known by construction.
#include "stereo_safety_map/core/evaluation_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

using L = SafetyLabel;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Characters: '.' unexamined, '?' unknown, 'L' level, 'I' inclined, 'N' non-ground.
L labelOf(char ch) {
  switch (ch) {
    case 'L':
      return L::kLevel;
    case 'I':
      return L::kInclined;
    case 'N':
      return L::kNonGround;
    case '?':
      return L::kUnknown;
    default:
      return L::kUnexamined;
  }
}

// Row i of the text is v = min_v + i, column j is u = min_u + j.
SafetyMap mapFromText(int min_u, int min_v, const std::vector<std::string>& rows) {
  SafetyMap m;
  m.min_u = min_u;
  m.min_v = min_v;
  m.width = static_cast<int>(rows[0].size());
  m.height = static_cast<int>(rows.size());
  m.resolution = 0.1;
  for (const std::string& r : rows)
    for (char ch : r)
      m.labels.push_back(labelOf(ch));
  m.segment.assign(m.labels.size(), -1);
  m.drop_off.assign(m.labels.size(), 0);
  return m;
}

LabelGrid gridFromText(int min_u, int min_v, const std::vector<std::string>& rows) {
  const SafetyMap m = mapFromText(min_u, min_v, rows);
  LabelGrid g;
  g.min_u = m.min_u;
  g.min_v = m.min_v;
  g.width = m.width;
  g.height = m.height;
  g.resolution = m.resolution;
  g.labels = m.labels;
  return g;
}

// ---------------------------------------------------------------------------------------------

TEST(SafetyClass, LevelAndInclinedAreSafeOnlyNonGroundIsUnsafe) {
  EXPECT_EQ(safetyClassOf(L::kLevel), SafetyClass::kSafe);
  EXPECT_EQ(safetyClassOf(L::kInclined), SafetyClass::kSafe);
  EXPECT_EQ(safetyClassOf(L::kNonGround), SafetyClass::kUnsafe);
  EXPECT_EQ(safetyClassOf(L::kUnknown), SafetyClass::kUnclassified);
  EXPECT_EQ(safetyClassOf(L::kUnexamined), SafetyClass::kUnclassified);
  EXPECT_EQ(safetyClassOf(static_cast<L>(200)), SafetyClass::kUnclassified);
}

TEST(CellOutcome, UnsafeIsThePositiveClass) {
  EXPECT_EQ(cellOutcome(L::kNonGround, L::kNonGround), CellOutcome::kTruePositive);
  EXPECT_EQ(cellOutcome(L::kNonGround, L::kLevel), CellOutcome::kFalsePositive);
  EXPECT_EQ(cellOutcome(L::kNonGround, L::kInclined), CellOutcome::kFalsePositive);
  EXPECT_EQ(cellOutcome(L::kLevel, L::kNonGround), CellOutcome::kFalseNegative);
  EXPECT_EQ(cellOutcome(L::kInclined, L::kNonGround), CellOutcome::kFalseNegative);
  EXPECT_EQ(cellOutcome(L::kLevel, L::kInclined), CellOutcome::kTrueNegative);
  EXPECT_EQ(cellOutcome(L::kInclined, L::kLevel), CellOutcome::kTrueNegative);
  for (L a : {L::kUnknown, L::kUnexamined}) {
    for (L b : {L::kUnexamined, L::kUnknown, L::kLevel, L::kInclined, L::kNonGround}) {
      EXPECT_EQ(cellOutcome(a, b), CellOutcome::kUnclassified);
      EXPECT_EQ(cellOutcome(b, a), CellOutcome::kUnclassified);
    }
  }
  EXPECT_STREQ(toString(CellOutcome::kFalseNegative), "FN");
}

TEST(CountConfusion, CountsEveryCellOfAHandMadePair) {
  // Same window. Expected per row (map vs GT):
  //  row 0: N/N TP, N/L FP, L/N FN, L/L TN, I/L TN
  //  row 1: ?/N -, ./L -, N/? -, L/. -, I/N FN
  //  row 2: N/I FP, N/N TP, I/I TN, L/N FN, N/N TP
  const SafetyMap map = mapFromText(-2, 5, {"NNLLI", "?.NLI", "NNILN"});
  const LabelGrid gt = gridFromText(-2, 5, {"NLNLL", "NL?.N", "ININN"});
  ConfusionCounts c;
  std::vector<CellOutcome> per_cell;
  ASSERT_EQ(countConfusion(map, gt, &c, &per_cell), "");
  EXPECT_EQ(c.tp, 3u);
  EXPECT_EQ(c.fp, 2u);
  EXPECT_EQ(c.fn, 3u);
  EXPECT_EQ(c.tn, 3u);
  EXPECT_EQ(c.unclassified_in_map, 2u);  // ?/N and ./L
  EXPECT_EQ(c.unclassified_in_gt, 2u);   // N/? and L/.
  EXPECT_EQ(c.maps, 1u);
  EXPECT_EQ(c.unsafeCells(), 6u);
  EXPECT_EQ(c.safeCells(), 5u);
  ASSERT_EQ(per_cell.size(), 15u);
  EXPECT_EQ(per_cell[0], CellOutcome::kTruePositive);
  EXPECT_EQ(per_cell[1], CellOutcome::kFalsePositive);
  EXPECT_EQ(per_cell[2], CellOutcome::kFalseNegative);
  EXPECT_EQ(per_cell[3], CellOutcome::kTrueNegative);
  EXPECT_EQ(per_cell[5], CellOutcome::kUnclassified);
  EXPECT_EQ(per_cell[9], CellOutcome::kFalseNegative);
  EXPECT_EQ(per_cell[13], CellOutcome::kFalseNegative);
}

TEST(CountConfusion, MatchesCellsByGlobalIndexNotByArrayPosition) {
  // The GT window starts one cell further in u and v: map cell (u, v) meets GT cell (u, v).
  //   map (u = 0..2, v = 0..1):  "NLL" / "LNL"
  //   GT  (u = 1..3, v = 1..2):  "NNN" / "LLL"
  // Overlap: (1,1) map N vs GT N -> TP; (2,1) map L vs GT N -> FN. The other 4 map cells are
  // classified but outside the GT.
  const SafetyMap map = mapFromText(0, 0, {"NLL", "LNL"});
  const LabelGrid gt = gridFromText(1, 1, {"NNN", "LLL"});
  ConfusionCounts c;
  ASSERT_EQ(countConfusion(map, gt, &c), "");
  EXPECT_EQ(c.tp, 1u);
  EXPECT_EQ(c.fn, 1u);
  EXPECT_EQ(c.fp, 0u);
  EXPECT_EQ(c.tn, 0u);
  EXPECT_EQ(c.unclassified_in_gt, 4u);
  EXPECT_EQ(c.unclassified_in_map, 0u);
}

TEST(CountConfusion, RefusesInconsistentInputWithoutCounting) {
  const SafetyMap map = mapFromText(0, 0, {"NL", "LN"});
  LabelGrid gt = gridFromText(0, 0, {"NL", "LN"});
  ConfusionCounts c;
  EXPECT_NE(countConfusion(map, gt, nullptr), "");

  SafetyMap bad = map;
  bad.labels.pop_back();
  EXPECT_NE(countConfusion(bad, gt, &c), "");
  bad = map;
  bad.resolution = kNaN;
  EXPECT_NE(countConfusion(bad, gt, &c), "");
  bad = map;
  bad.width = -2;
  EXPECT_NE(countConfusion(bad, gt, &c), "");

  LabelGrid bad_gt = gt;
  bad_gt.labels.push_back(L::kLevel);
  EXPECT_NE(countConfusion(map, bad_gt, &c), "");
  bad_gt = gt;
  bad_gt.resolution = 0.2;
  const std::string err = countConfusion(map, bad_gt, &c);
  EXPECT_NE(err.find("resolution"), std::string::npos) << err;
  bad_gt.resolution = 0.0;
  EXPECT_NE(countConfusion(map, bad_gt, &c), "");
  EXPECT_EQ(c.maps, 0u);
  EXPECT_EQ(c.classified(), 0u);

  // An empty map is valid and counts one map with nothing in it.
  SafetyMap empty;
  ASSERT_EQ(countConfusion(empty, gt, &c), "");
  EXPECT_EQ(c.maps, 1u);
  EXPECT_EQ(c.classified(), 0u);
}

TEST(ErrorRates, DatasetRatesComeFromSumsNotFromMeansOfFrames) {
  // Frame 1: 1 unsafe cell, missed (FN rate 1). Frame 2: 9 unsafe cells, all found (FN rate 0).
  // Sum: FN 1 of 10 unsafe -> 0.1 (the mean of the frames' rates would be 0.5).
  ConfusionCounts f1;
  f1.fn = 1;
  f1.tn = 4;
  f1.maps = 1;
  ConfusionCounts f2;
  f2.tp = 9;
  f2.fp = 1;
  f2.tn = 5;
  f2.maps = 1;
  ConfusionCounts sum;
  sum += f1;
  sum += f2;
  EXPECT_EQ(sum.maps, 2u);
  const ErrorRates r = errorRates(sum);
  EXPECT_DOUBLE_EQ(r.fn, 0.1);
  EXPECT_DOUBLE_EQ(r.tp, 0.9);
  EXPECT_DOUBLE_EQ(r.fp, 0.1);  // 1 of 10 safe cells
  EXPECT_DOUBLE_EQ(r.tn, 0.9);
  EXPECT_DOUBLE_EQ(errorRates(f1).fn, 1.0);
  EXPECT_DOUBLE_EQ(errorRates(f2).fn, 0.0);
}

TEST(ErrorRates, NaNWithoutCellsOfAClass) {
  ConfusionCounts only_safe;
  only_safe.tn = 7;
  only_safe.fp = 3;
  const ErrorRates r = errorRates(only_safe);
  EXPECT_TRUE(std::isnan(r.fn));
  EXPECT_TRUE(std::isnan(r.tp));
  EXPECT_DOUBLE_EQ(r.fp, 0.3);
  EXPECT_DOUBLE_EQ(r.tn, 0.7);
  const ErrorRates none = errorRates(ConfusionCounts());
  EXPECT_TRUE(std::isnan(none.fp));
}

TEST(SafeClassScores, FollowPaper001WithSafeAsPositive) {
  // A (safe in both) = TN = 8, B (safe in map, unsafe in GT) = FN = 2, C (unsafe in map, safe in
  // GT) = FP = 4; TP does not enter.
  ConfusionCounts c;
  c.tn = 8;
  c.fn = 2;
  c.fp = 4;
  c.tp = 100;
  const SafeClassScores s = safeClassScores(c);
  EXPECT_DOUBLE_EQ(s.precision, 8.0 / 10.0);
  EXPECT_DOUBLE_EQ(s.recall, 8.0 / 12.0);
  EXPECT_DOUBLE_EQ(s.f1, 16.0 / 22.0);
  EXPECT_NEAR(s.f1, 2 * s.precision * s.recall / (s.precision + s.recall), 1e-12);
  EXPECT_TRUE(std::isnan(safeClassScores(ConfusionCounts()).precision));
}

TEST(MeanStd, SampleStandardDeviationSkippingNaN) {
  const MeanStd a = meanStd({1.0, 2.0, 3.0, 4.0, kNaN});
  EXPECT_EQ(a.n, 4);
  EXPECT_DOUBLE_EQ(a.mean, 2.5);
  EXPECT_NEAR(a.stddev, std::sqrt(5.0 / 3.0), 1e-12);
  const MeanStd one = meanStd({0.25});
  EXPECT_DOUBLE_EQ(one.mean, 0.25);
  EXPECT_DOUBLE_EQ(one.stddev, 0.0);
  const MeanStd none = meanStd({kNaN, std::numeric_limits<double>::infinity()});
  EXPECT_EQ(none.n, 0);
  EXPECT_TRUE(std::isnan(none.mean));
  EXPECT_TRUE(std::isnan(meanStd({}).stddev));
}

// ---------------------------------------------------------------------------------------------
// Plane accuracy

ReferencePlane square(const std::string& name, double x0, double y0, double x1, double y1, double a,
                      double b, double c, bool clockwise = false) {
  ReferencePlane p;
  p.name = name;
  p.a = a;
  p.b = b;
  p.c = c;
  p.footprint = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  if (clockwise) std::swap(p.footprint[1], p.footprint[3]);
  return p;
}

GroundPlane plane(double a, double b, double c) {
  GroundPlane p;
  p.valid = true;
  p.a = a;
  p.b = b;
  p.c = c;
  p.normal = Eigen::Vector3d(-a, -b, 1.0).normalized();
  return p;
}

// A 10 x 10 map over u, v in [0, 9]; footprint = cells of the given u range, all v.
std::vector<int> footprint(const SafetyMap& m, int u0, int u1) {
  std::vector<int> cells;
  for (int v = m.min_v; v < m.min_v + m.height; ++v)
    for (int u = u0; u <= u1; ++u)
      cells.push_back(m.index(u, v));
  return cells;
}

SafetyMap emptyMap(int w, int h) {
  SafetyMap m;
  m.width = w;
  m.height = h;
  m.labels.assign(static_cast<std::size_t>(w) * h, L::kLevel);
  return m;
}

TEST(ReferencePlane, ContainsWorksForBothOrientationsAndBorders) {
  for (bool cw : {false, true}) {
    const ReferencePlane p = square("s", 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, cw);
    EXPECT_TRUE(p.contains(0.5, 1.0));
    EXPECT_TRUE(p.contains(0.0, 0.0));  // corner
    EXPECT_TRUE(p.contains(1.0, 1.5));  // edge
    EXPECT_FALSE(p.contains(1.01, 1.0));
    EXPECT_FALSE(p.contains(0.5, -0.01));
    EXPECT_FALSE(p.contains(kNaN, 0.5));
  }
  ReferencePlane degenerate;
  degenerate.footprint = {{0.0, 0.0}, {1.0, 0.0}};
  EXPECT_FALSE(degenerate.contains(0.5, 0.0));
}

TEST(ReferencePlane, TopSurfaceIsTheHighestContainingPlane) {
  const std::vector<ReferencePlane> refs = {square("floor", -5, -5, 5, 5, 0, 0, 0.0),
                                            square("platform", 0, 0, 1, 1, 0, 0, 0.3),
                                            square("pit", 2, 2, 3, 3, 0, 0, -0.5)};
  EXPECT_EQ(topReferencePlane(refs, 0.5, 0.5), 1);
  EXPECT_EQ(topReferencePlane(refs, 2.5, 2.5), 0);
  EXPECT_EQ(topReferencePlane(refs, -3.0, 1.0), 0);
  EXPECT_EQ(topReferencePlane(refs, 9.0, 9.0), -1);
}

TEST(ComparePlane, AngleAndDistanceOfKnownPlanes) {
  const SafetyMap m = emptyMap(10, 10);  // cells centred at 0.0 .. 0.9 in x and y
  const std::vector<ReferencePlane> refs = {square("floor", -1, -1, 2, 2, 0, 0, 0.0)};

  // Parallel, 2 cm above: angle 0, distance 0.02 everywhere.
  PlaneAccuracy r = comparePlane(plane(0, 0, 0.02), footprint(m, 0, 9), m, refs);
  ASSERT_TRUE(r.matched);
  EXPECT_EQ(r.reference, 0);
  EXPECT_EQ(r.cells, 100);
  EXPECT_EQ(r.cells_on_reference, 100);
  EXPECT_NEAR(r.angle_deg, 0.0, 1e-6);
  EXPECT_NEAR(r.mean_distance, 0.02, 1e-12);
  EXPECT_NEAR(r.max_distance, 0.02, 1e-12);

  // Tilted by 2 deg about the y axis through x = 0.45: |z| = tan(2 deg) |x - 0.45|, mean over the
  // cell centres x = 0.0 .. 0.9 of |x - 0.45| = 0.25.
  const double t = std::tan(2.0 * M_PI / 180.0);
  r = comparePlane(plane(t, 0, -0.45 * t), footprint(m, 0, 9), m, refs);
  ASSERT_TRUE(r.matched);
  EXPECT_NEAR(r.angle_deg, 2.0, 1e-9);
  EXPECT_NEAR(r.mean_distance, 0.25 * t, 1e-12);
  EXPECT_NEAR(r.max_distance, 0.45 * t, 1e-12);
}

TEST(ComparePlane, DistanceIsPerpendicularToAnInclinedReference) {
  const SafetyMap m = emptyMap(10, 10);
  const double s = std::tan(6.0 * M_PI / 180.0);
  const std::vector<ReferencePlane> refs = {square("ramp", -1, -1, 2, 2, s, 0, 0.1)};
  // Detected: the same ramp 5 cm higher (vertically) -> perpendicular 0.05 cos(6 deg).
  const PlaneAccuracy r = comparePlane(plane(s, 0, 0.15), footprint(m, 0, 9), m, refs);
  ASSERT_TRUE(r.matched);
  EXPECT_NEAR(r.angle_deg, 0.0, 1e-6);
  EXPECT_NEAR(r.mean_distance, 0.05 * std::cos(6.0 * M_PI / 180.0), 1e-12);
}

TEST(ComparePlane, MatchesTheReferenceUnderMostOfTheFootprint) {
  const SafetyMap m = emptyMap(10, 10);
  // Floor under x < 0.65 (u = 0..6, 70 cells), a 0.2 m platform under u = 7..9 (30 cells).
  const std::vector<ReferencePlane> refs = {square("floor", -1, -1, 0.65, 2, 0, 0, 0.0),
                                            square("platform", 0.65, -1, 2, 2, 0, 0, 0.2)};
  const PlaneAccuracy r = comparePlane(plane(0, 0, 0.01), footprint(m, 0, 9), m, refs);
  ASSERT_TRUE(r.matched);
  EXPECT_EQ(r.reference, 0);
  EXPECT_EQ(r.cells_on_reference, 70);
  // Distance to the matched (floor) plane over the whole footprint.
  EXPECT_NEAR(r.mean_distance, 0.01, 1e-12);

  const PlaneAccuracy p = comparePlane(plane(0, 0, 0.19), footprint(m, 7, 9), m, refs);
  ASSERT_TRUE(p.matched);
  EXPECT_EQ(p.reference, 1);
  EXPECT_NEAR(p.mean_distance, 0.01, 1e-12);
}

TEST(ComparePlane, UnmatchedForInvalidOrUnsupportedInput) {
  const SafetyMap m = emptyMap(10, 10);
  const std::vector<ReferencePlane> refs = {square("floor", -1, -1, 2, 2, 0, 0, 0.0)};
  GroundPlane invalid = plane(0, 0, 0);
  invalid.valid = false;
  EXPECT_FALSE(comparePlane(invalid, footprint(m, 0, 9), m, refs).matched);
  EXPECT_FALSE(comparePlane(plane(0, 0, 0), {}, m, refs).matched);
  EXPECT_FALSE(comparePlane(plane(0, 0, 0), footprint(m, 0, 9), m, {}).matched);
  // Out-of-range cell indices are ignored.
  const PlaneAccuracy r = comparePlane(plane(0, 0, 0), {-5, 1000, 0}, m, refs);
  EXPECT_TRUE(r.matched);
  EXPECT_EQ(r.cells, 1);
  // Footprint away from every reference.
  const std::vector<ReferencePlane> far = {square("far", 50, 50, 60, 60, 0, 0, 0)};
  EXPECT_FALSE(comparePlane(plane(0, 0, 0), footprint(m, 0, 9), m, far).matched);
}

// ---------------------------------------------------------------------------------------------
// Board coverage (frame latency)

VoxelGrid gridAroundOrigin() {
  VoxelGrid g;
  g.recenter(Eigen::Vector3f::Zero());
  return g;
}

void occupy(VoxelGrid* g, int u, int v, int w) {
  g->setLogOdds(VoxelIndex{u, v, w}, 200);
}

// Board 1 m wide (along y), 5 cm thick (along x), 1 m high, standing on the floor at x = 3.
BoardBox boardAt3m() {
  BoardBox b;
  b.center = Eigen::Vector3d(3.0, 0.0, 0.5);
  b.half_size = Eigen::Vector3d(0.025, 0.5, 0.5);
  return b;
}

TEST(BoardCoverage, CountsWidthSamplesWithOccupiedVoxelsOnTheBoard) {
  VoxelGrid g = gridAroundOrigin();
  const BoardBox b = boardAt3m();
  BoardCoverage c = boardWidthCoverage(g, b);
  EXPECT_EQ(c.bins, 10);
  EXPECT_EQ(c.covered, 0);
  EXPECT_DOUBLE_EQ(c.fraction(), 0.0);

  // The floor all along the board does not count, nor do voxels 1 m behind it.
  for (int v = -6; v <= 6; ++v)
    occupy(&g, 30, v, 0);
  for (int v = -6; v <= 6; ++v)
    occupy(&g, 40, v, 5);
  EXPECT_EQ(boardWidthCoverage(g, b).covered, 0);

  // Voxel columns v = -5 .. -1 (y = -0.5 .. -0.1) at mid height: the board's samples at
  // y = -0.45 .. -0.05 lie within half a voxel of them -> 5 of 10.
  for (int v = -5; v <= -1; ++v)
    occupy(&g, 30, v, 5);
  c = boardWidthCoverage(g, b);
  EXPECT_EQ(c.covered, 5);
  EXPECT_DOUBLE_EQ(c.fraction(), 0.5);
  EXPECT_EQ(framesUntilCoverage({0.0, 0.2, c.fraction(), 1.0}, 0.5), 3);

  // A voxel next to the board (one voxel in front of its face) still overlaps it.
  for (int v = 0; v <= 5; ++v)
    occupy(&g, 29, v, 7);
  EXPECT_EQ(boardWidthCoverage(g, b).covered, 10);
}

TEST(BoardCoverage, BinsOfTheGridAndOfMarkedCellsCombine) {
  VoxelGrid g = gridAroundOrigin();
  // Shifted by 2 cm so that no sample lies on a cell border: samples at y = -0.43 + 0.1 k.
  BoardBox b = boardAt3m();
  b.center.y() = 0.02;
  for (int v = -5; v <= -1; ++v)  // voxels centred at y = -0.5 .. -0.1: samples -0.43 .. -0.13
    occupy(&g, 30, v, 5);
  std::vector<std::uint8_t> bins;
  EXPECT_EQ(boardWidthCoverage(g, b, &bins).covered, 4);
  ASSERT_EQ(bins.size(), 10u);
  EXPECT_EQ(std::count(bins.begin(), bins.end(), 1), 4);
  EXPECT_EQ(bins[0], 1);
  EXPECT_EQ(bins[4], 0);

  // A 2D map over u 20..39, v -10..9. Marked: (30, 3) holds the sample y = 0.27, (31, 4) lies
  // one cell behind the face (x = 3.1, within the slack) and holds y = 0.37, (30, 5) y = 0.47.
  SafetyMap m;
  m.min_u = 20;
  m.min_v = -10;
  m.width = 20;
  m.height = 20;
  m.resolution = 0.1;
  m.labels.assign(400, SafetyLabel::kLevel);
  std::vector<std::uint8_t> marked(400, 0);
  marked[m.index(30, 3)] = 1;
  marked[m.index(31, 4)] = 1;
  marked[m.index(30, 5)] = 1;
  std::vector<std::uint8_t> cells_only;
  const BoardCoverage c = boardWidthCoverageOfCells(m, marked, b, &cells_only);
  EXPECT_EQ(c.bins, 10);
  EXPECT_EQ(c.covered, 3);
  ASSERT_EQ(cells_only.size(), 10u);
  EXPECT_EQ(cells_only[7], 1);
  EXPECT_EQ(cells_only[8], 1);
  EXPECT_EQ(cells_only[9], 1);
  // OR-ed into the grid's bins: 4 + 3.
  boardWidthCoverageOfCells(m, marked, b, &bins);
  EXPECT_EQ(std::count(bins.begin(), bins.end(), 1), 7);
  // A cell two cells in front of the face is beyond the slack; a wrong-sized mask gives nothing.
  std::vector<std::uint8_t> far(400, 0);
  far[m.index(28, 0)] = 1;
  EXPECT_EQ(boardWidthCoverageOfCells(m, far, b).covered, 0);
  EXPECT_EQ(boardWidthCoverageOfCells(m, std::vector<std::uint8_t>(3, 1), b).bins, 0);
}

TEST(BoardCoverage, RotatedBoard) {
  VoxelGrid g = gridAroundOrigin();
  BoardBox b;
  // 1.4 m wide along the diagonal x = y, centred at (2, 2).
  b.center = Eigen::Vector3d(2.0, 2.0, 0.5);
  b.rotation = Eigen::AngleAxisd(M_PI / 4.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  b.half_size = Eigen::Vector3d(0.7, 0.03, 0.5);  // width along the box's x axis
  EXPECT_EQ(boardWidthCoverage(g, b).bins, 14);
  // Voxels on the diagonal u = v from 15 to 25 (x = y = 1.5 .. 2.5).
  for (int k = 15; k <= 25; ++k)
    occupy(&g, k, k, 4);
  const BoardCoverage c = boardWidthCoverage(g, b);
  EXPECT_EQ(c.covered, 14);
  // The first half of the diagonal only.
  VoxelGrid h = gridAroundOrigin();
  for (int k = 15; k <= 19; ++k)
    occupy(&h, k, k, 4);
  const BoardCoverage half = boardWidthCoverage(h, b);
  EXPECT_GE(half.covered, 6);
  EXPECT_LE(half.covered, 8);
}

TEST(BoardCoverage, BadBoardsGiveNothing) {
  const VoxelGrid g = gridAroundOrigin();
  BoardBox b = boardAt3m();
  b.center.x() = kNaN;
  EXPECT_EQ(boardWidthCoverage(g, b).bins, 0);
  b = boardAt3m();
  b.half_size.y() = -1.0;
  EXPECT_EQ(boardWidthCoverage(g, b).bins, 0);
  b = boardAt3m();
  b.center.x() = 1e30;  // far outside the window: bins but nothing covered, no crash
  EXPECT_EQ(boardWidthCoverage(g, b).covered, 0);
}

TEST(FramesUntilCoverage, FirstFrameReachingTheFraction) {
  EXPECT_EQ(framesUntilCoverage({}, 0.5), -1);
  EXPECT_EQ(framesUntilCoverage({0.1, 0.4, 0.49}, 0.5), -1);
  EXPECT_EQ(framesUntilCoverage({0.5}, 0.5), 1);
  EXPECT_EQ(framesUntilCoverage({0.0, 0.6, 0.3, 0.95}, 0.9), 4);
  EXPECT_EQ(framesUntilCoverage({0.0, kNaN, 0.9}, 0.9), 3);
}

}  // namespace
}  // namespace stereo_safety_map
