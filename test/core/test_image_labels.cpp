// Hand labels of an image and the score of a safety map against them (image_labels.h): the parser
// and its errors, the rasteriser's override order, and the scoring on a constructed scene whose
// answer is known by construction (a camera looking straight down on a floor with a box).
#include "stereo_safety_map/core/image_labels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace stereo_safety_map {
namespace {

// ---------------------------------------------------------------------------------------------
// Parser

TEST(ImageLabelNames, RoundTrip) {
  for (int k = 1; k < kNumImageLabels; ++k) {
    const ImageLabel l = static_cast<ImageLabel>(k);
    ImageLabel back = ImageLabel::kNone;
    ASSERT_TRUE(imageLabelFromString(toString(l), &back)) << toString(l);
    EXPECT_EQ(back, l);
  }
  EXPECT_FALSE(imageLabelFromString("none", nullptr));  // not a class of the file
  EXPECT_FALSE(imageLabelFromString("Floor", nullptr));
  EXPECT_EQ(safetyClassOf(ImageLabel::kFloor), SafetyClass::kSafe);
  EXPECT_EQ(safetyClassOf(ImageLabel::kObstacle), SafetyClass::kUnsafe);
  EXPECT_EQ(safetyClassOf(ImageLabel::kOverhang), SafetyClass::kUnsafe);
  EXPECT_EQ(safetyClassOf(ImageLabel::kDropOff), SafetyClass::kUnsafe);
  EXPECT_EQ(safetyClassOf(ImageLabel::kIgnore), SafetyClass::kUnclassified);
  EXPECT_EQ(safetyClassOf(ImageLabel::kNone), SafetyClass::kUnclassified);
}

TEST(ParseImageLabels, ReadsSizePolygonsAndComments) {
  const std::string text =
      "# a comment line\n"
      "\n"
      "size 640 480   # trailing comment\n"
      "floor 0,300 640,300 640,480 0,480\n"
      "  obstacle 10,10 20,10 20,20   \n"
      "overhang 1,1 2,1 2,2 # comment after the vertices\n"
      "drop_off 5,5 6,5 6,6\n"
      "ignore 0,0 640,0 640,100\n";
  ImageLabels l;
  ASSERT_EQ(parseImageLabels(text, &l), "");
  EXPECT_EQ(l.width, 640);
  EXPECT_EQ(l.height, 480);
  ASSERT_EQ(l.polygons.size(), 5u);
  EXPECT_EQ(l.polygons[0].label, ImageLabel::kFloor);
  EXPECT_EQ(l.polygons[0].line, 4);
  ASSERT_EQ(l.polygons[0].vertices.size(), 4u);
  EXPECT_EQ(l.polygons[0].vertices[1], cv::Point(640, 300));
  EXPECT_EQ(l.polygons[1].label, ImageLabel::kObstacle);
  EXPECT_EQ(l.polygons[1].line, 5);
  EXPECT_EQ(l.polygons[2].label, ImageLabel::kOverhang);
  EXPECT_EQ(l.polygons[3].label, ImageLabel::kDropOff);
  EXPECT_EQ(l.polygons[4].label, ImageLabel::kIgnore);
}

TEST(ParseImageLabels, ErrorsNameTheLine) {
  struct Case {
    const char* text;
    const char* expected;  // substring of the error
  };
  const Case cases[] = {
      {"size 64 48\nflor 0,0 1,0 1,1\n", "line 2: unknown class 'flor'"},
      {"size 64 48\nfloor 0,0 1,0\n", "line 2: floor polygon has 2 vertices, needs at least 3"},
      {"size 64 48\n\nfloor 0,0 1;0 1,1\n", "line 3: bad vertex '1;0'"},
      {"size 64 48\nfloor 0,0 1,0 1,x\n", "line 2: bad vertex '1,x'"},
      {"size 64 48\nfloor 0,0 1.5,0 1,1\n", "line 2: bad vertex '1.5,0'"},
      {"size 64 48\nfloor 0,0 65,0 1,1\n", "line 2: vertex 65,0 outside the 64x48 image"},
      {"size 64 48\nfloor 0,0 -1,0 1,1\n", "line 2: vertex -1,0 outside"},
      {"floor 0,0 1,0 1,1\nsize 64 48\n", "line 1: polygon before the 'size"},
      {"size 64 48\nsize 64 48\n", "line 2: repeated size line"},
      {"size 64\n", "line 1: expected 'size <width> <height>'"},
      {"size 64 48 3\n", "line 1: expected 'size <width> <height>'"},
      {"size 0 48\n", "line 1: image size 0 x 48 must be in"},
      {"# only a comment\n", "no 'size <width> <height>' line"},
  };
  for (const Case& c : cases) {
    ImageLabels l;
    l.width = 7;  // untouched on error
    const std::string err = parseImageLabels(c.text, &l);
    EXPECT_NE(err.find(c.expected), std::string::npos) << "text:\n" << c.text << "error: " << err;
    EXPECT_EQ(l.width, 7);
  }
  // The image border may be named (x = width, y = height).
  ImageLabels l;
  EXPECT_EQ(parseImageLabels("size 64 48\nfloor 0,0 64,0 64,48 0,48\n", &l), "");
}

TEST(LoadImageLabels, MissingFileNamesThePath) {
  ImageLabels l;
  const std::string err = loadImageLabels("/nonexistent/labels.txt", &l);
  EXPECT_NE(err.find("/nonexistent/labels.txt"), std::string::npos) << err;
}

// ---------------------------------------------------------------------------------------------
// Rasteriser

TEST(RasteriseImageLabels, FillsPolygonsInclusiveAndLaterOnesOnTop) {
  ImageLabels l;
  ASSERT_EQ(parseImageLabels("size 40 30\n"
                             "floor 0,10 40,10 40,30 0,30\n"     // rows 10..29
                             "obstacle 10,5 19,5 19,14 10,14\n"  // over the floor's top
                             "floor 12,12 13,12 13,13 12,13\n"   // back to floor inside it
                             "ignore 30,0 40,0 40,30 30,30\n",   // columns 30..39
                             &l),
            "");
  cv::Mat img;
  ASSERT_EQ(rasteriseImageLabels(l, &img), "");
  ASSERT_EQ(img.type(), CV_8UC1);
  ASSERT_EQ(img.cols, 40);
  ASSERT_EQ(img.rows, 30);
  auto at = [&](int x, int y) { return static_cast<ImageLabel>(img.at<std::uint8_t>(y, x)); };
  EXPECT_EQ(at(0, 9), ImageLabel::kNone);
  EXPECT_EQ(at(0, 10), ImageLabel::kFloor);
  EXPECT_EQ(at(5, 29), ImageLabel::kFloor);
  EXPECT_EQ(at(10, 5), ImageLabel::kObstacle);  // vertices and edges belong to the polygon
  EXPECT_EQ(at(19, 14), ImageLabel::kObstacle);
  EXPECT_EQ(at(20, 14), ImageLabel::kFloor);
  EXPECT_EQ(at(9, 5), ImageLabel::kNone);
  EXPECT_EQ(at(12, 12), ImageLabel::kFloor);  // the later floor square
  EXPECT_EQ(at(13, 13), ImageLabel::kFloor);
  EXPECT_EQ(at(14, 13), ImageLabel::kObstacle);
  EXPECT_EQ(at(30, 20), ImageLabel::kIgnore);
  EXPECT_EQ(at(30, 0), ImageLabel::kIgnore);
  EXPECT_EQ(at(29, 20), ImageLabel::kFloor);
  // Pixel counts: obstacle 10 x 10 minus the 2 x 2 floor square.
  EXPECT_EQ(cv::countNonZero(img == static_cast<int>(ImageLabel::kObstacle)), 96);
  EXPECT_EQ(cv::countNonZero(img == static_cast<int>(ImageLabel::kIgnore)), 10 * 30);

  ImageLabels empty;
  EXPECT_NE(rasteriseImageLabels(empty, &img), "");
}

// ---------------------------------------------------------------------------------------------
// Scoring on a constructed scene.
//
// A 100 x 100 camera (f = 100 px, baseline 0.1 m, cx = cy = 50.25) 2 m above the floor looks
// straight down: optical x = fixed x, optical y = -fixed y, optical z = -fixed z. A floor pixel
// (disparity 5, Z = 2 m) lands in cell (round((u - 50.25) / 5), round(-(v - 50.25) / 5)): 5 x 5
// pixels per cell, never closer than 0.05 cells to a cell border. A box whose top is 1 m above the
// floor fills pixels u 66..85, v 46..55 (disparity 10, Z = 1 m): 10 x 10 pixels per cell, its top
// in cells (2, 0) (u 66..75) and (3, 0) (u 76..85). Cells (4..6, 0) lie in its shadow: every floor
// pixel of theirs is box in the image, so they get no vote. Cell (2, 0) also gets 25 floor votes
// (u 58..62), cell (3, 0) 15 (u 63..65): both are obstacle by majority. Cell (7, 0) gets 10 floor
// votes (u 86, 87).
// Columns u 0..2 (cell column -10) have no disparity; rows v 93..99 (cell rows -9 and -10) are
// labelled ignore. The map's grid is cells -10..10 both ways, column u = 10 Unexamined.

constexpr int kSide = 100;

StereoCameraModel downCamera() {
  StereoCameraModel c;
  c.fx = c.fy = 100.0;
  c.cx = c.cy = c.cx_right = 50.25;
  c.baseline = 0.1;
  c.width = c.height = kSide;
  return c;
}

Eigen::Isometry3d downPose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  T.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
  return T;
}

bool inBox(int u, int v) {
  return u >= 66 && u <= 85 && v >= 46 && v <= 55;
}

cv::Mat boxDisparity() {
  cv::Mat d(kSide, kSide, CV_32F, cv::Scalar(5.0f));
  for (int v = 0; v < kSide; ++v)
    for (int u = 0; u < kSide; ++u) {
      if (inBox(u, v)) d.at<float>(v, u) = 10.0f;
      if (u <= 2) d.at<float>(v, u) = (v % 2) ? 0.0f : std::nanf("");  // no disparity
    }
  return d;
}

cv::Mat boxLabels() {
  ImageLabels l;
  EXPECT_EQ(parseImageLabels("size 100 100\n"
                             "floor 0,0 100,0 100,100 0,100\n"
                             "obstacle 66,46 85,46 85,55 66,55\n"
                             "ignore 0,93 100,93 100,100 0,100\n",
                             &l),
            "");
  cv::Mat img;
  EXPECT_EQ(rasteriseImageLabels(l, &img), "");
  return img;
}

SafetyMap levelMap() {
  SafetyMap m;
  m.min_u = m.min_v = -10;
  m.width = m.height = 21;
  m.resolution = 0.1;
  m.labels.assign(21 * 21, SafetyLabel::kLevel);
  for (int v = -10; v <= 10; ++v)
    m.labels[m.index(10, v)] = SafetyLabel::kUnexamined;  // beyond R_max
  return m;
}

TEST(ScoreAgainstImageLabels, PerfectMapOfTheBoxScene) {
  SafetyMap m = levelMap();
  m.labels[m.index(2, 0)] = m.labels[m.index(3, 0)] = SafetyLabel::kNonGround;
  ImageLabelScore s;
  ASSERT_EQ(scoreAgainstImageLabels(boxLabels(), boxDisparity(), downCamera(), downPose(), m,
                                    LabelScoringConfig(), &s),
            "");
  // 441 cells - 3 in the shadow - 21 without disparity (column -10) - 42 ignored (rows -9, -10)
  // + 2 counted twice = 377 with a truth; 19 of them in the Unexamined column (rows -8..10).
  EXPECT_EQ(s.truth_cells, 358);
  EXPECT_EQ(s.truth_cells_beyond, 19);
  EXPECT_EQ(s.covered_cells, 358);
  EXPECT_DOUBLE_EQ(s.coverage(), 1.0);
  EXPECT_EQ(s.exact.tp, 2u);
  EXPECT_EQ(s.exact.tn, 356u);
  EXPECT_EQ(s.exact.fp + s.exact.fn, 0u);
  EXPECT_EQ(s.cells_tied, 0);
  EXPECT_EQ(s.cells_too_few_votes, 0);
  EXPECT_EQ(s.truth[m.index(2, 0)], ImageLabel::kObstacle);
  EXPECT_EQ(s.truth[m.index(3, 0)], ImageLabel::kObstacle);
  EXPECT_EQ(s.truth[m.index(4, 0)], ImageLabel::kNone);  // shadow
  EXPECT_EQ(s.truth[m.index(6, 0)], ImageLabel::kNone);
  EXPECT_EQ(s.truth[m.index(7, 0)], ImageLabel::kFloor);
  EXPECT_EQ(s.truth[m.index(-10, 0)], ImageLabel::kNone);  // no disparity
  EXPECT_EQ(s.truth[m.index(0, -9)], ImageLabel::kNone);   // ignore
  EXPECT_EQ(s.truth[m.index(0, -8)], ImageLabel::kFloor);
  EXPECT_EQ(s.truth[m.index(10, 0)], ImageLabel::kFloor);  // beyond R_max, still a truth
  EXPECT_EQ(s.outcomes[m.index(2, 0)], CellOutcome::kTruePositive);
  EXPECT_EQ(s.outcomes[m.index(10, 0)], CellOutcome::kUnclassified);
  // Pixels: 200 box, 700 ignore, 9100 floor of which 3 columns x 93 rows have no disparity.
  const LabelClassScore& fl = s.classes[static_cast<int>(ImageLabel::kFloor)];
  const LabelClassScore& ob = s.classes[static_cast<int>(ImageLabel::kObstacle)];
  const LabelClassScore& ig = s.classes[static_cast<int>(ImageLabel::kIgnore)];
  EXPECT_EQ(fl.pixels, 9100u);
  EXPECT_EQ(fl.pixels_with_disparity, 9100u - 279u);
  EXPECT_EQ(fl.pixels_voting, 9100u - 279u);
  EXPECT_EQ(ob.pixels, 200u);
  EXPECT_EQ(ob.pixels_with_disparity, 200u);
  EXPECT_EQ(ig.pixels, 700u);
  EXPECT_EQ(ig.pixels_with_disparity, 700u - 21u);
  EXPECT_EQ(ig.pixels_voting, 0u);  // ignore never votes
  EXPECT_EQ(fl.cells, 356);
  EXPECT_EQ(fl.cells_beyond, 19);
  EXPECT_EQ(ob.cells, 2);
  EXPECT_DOUBLE_EQ(fl.recall(), 1.0);
  EXPECT_DOUBLE_EQ(ob.recall(), 1.0);
  EXPECT_TRUE(std::isnan(s.classes[static_cast<int>(ImageLabel::kOverhang)].recall()));
  // Map-classified cells without a truth: 64 minus the 2 Unexamined ones among them.
  EXPECT_EQ(s.exact.unclassified_in_gt, 62u);
}

TEST(ScoreAgainstImageLabels, ErrorsCoverageAndTheOneCellTolerance) {
  SafetyMap m = levelMap();
  m.labels[m.index(2, 0)] = SafetyLabel::kNonGround;    // TP
  m.labels[m.index(3, 0)] = SafetyLabel::kLevel;        // FN beside the floor cell (4, 1): forgiven
  m.labels[m.index(1, 0)] = SafetyLabel::kNonGround;    // FP beside the box cell (2, 0): forgiven
  m.labels[m.index(-5, -5)] = SafetyLabel::kNonGround;  // FP amid floor: stays
  m.labels[m.index(-8, 0)] = SafetyLabel::kUnknown;     // hedged: not covered
  m.labels[m.index(-8, 1)] = SafetyLabel::kUnknown;
  ImageLabelScore s;
  ASSERT_EQ(scoreAgainstImageLabels(boxLabels(), boxDisparity(), downCamera(), downPose(), m,
                                    LabelScoringConfig(), &s),
            "");
  EXPECT_EQ(s.truth_cells, 358);
  EXPECT_EQ(s.covered_cells, 356);
  EXPECT_DOUBLE_EQ(s.coverage(), 356.0 / 358.0);
  EXPECT_EQ(s.exact.tp, 1u);
  EXPECT_EQ(s.exact.fn, 1u);
  EXPECT_EQ(s.exact.fp, 2u);
  EXPECT_EQ(s.exact.tn, 352u);
  EXPECT_EQ(s.exact.unclassified_in_map, 2u);
  const ErrorRates r = errorRates(s.exact);
  EXPECT_DOUBLE_EQ(r.fn, 0.5);
  EXPECT_DOUBLE_EQ(r.fp, 2.0 / 354.0);
  // Tolerance: the forgiven FN counts as TP, the forgiven FP as TN.
  EXPECT_EQ(s.tolerant.tp, 2u);
  EXPECT_EQ(s.tolerant.fn, 0u);
  EXPECT_EQ(s.tolerant.fp, 1u);
  EXPECT_EQ(s.tolerant.tn, 353u);
  EXPECT_EQ(s.outcomes[m.index(3, 0)], CellOutcome::kFalseNegative);
  EXPECT_EQ(s.outcomes[m.index(-5, -5)], CellOutcome::kFalsePositive);
  EXPECT_EQ(s.outcomes[m.index(-8, 0)], CellOutcome::kUnclassified);

  const LabelClassScore& fl = s.classes[static_cast<int>(ImageLabel::kFloor)];
  const LabelClassScore& ob = s.classes[static_cast<int>(ImageLabel::kObstacle)];
  EXPECT_EQ(fl.cells, 356);
  EXPECT_EQ(fl.map_safe, 352);
  EXPECT_EQ(fl.map_non_ground, 2);
  EXPECT_EQ(fl.map_unknown, 2);
  EXPECT_DOUBLE_EQ(fl.recall(), 352.0 / 356.0);  // Unknown is a miss
  EXPECT_DOUBLE_EQ(fl.recallTolerant(), 353.0 / 356.0);
  EXPECT_EQ(ob.map_safe, 1);
  EXPECT_EQ(ob.map_non_ground, 1);
  EXPECT_DOUBLE_EQ(ob.recall(), 0.5);
  EXPECT_DOUBLE_EQ(ob.recallTolerant(), 1.0);

  // Without tolerance the tolerant counts are the exact ones.
  LabelScoringConfig strict;
  strict.tolerance_cells = 0;
  ASSERT_EQ(
      scoreAgainstImageLabels(boxLabels(), boxDisparity(), downCamera(), downPose(), m, strict, &s),
      "");
  EXPECT_EQ(s.tolerant.tp, 1u);
  EXPECT_EQ(s.tolerant.fn, 1u);
  EXPECT_EQ(s.tolerant.fp, 2u);
  EXPECT_EQ(s.tolerant.tn, 352u);
}

TEST(ScoreAgainstImageLabels, AMapThatHedgesLosesCoverageAndRecall) {
  SafetyMap m = levelMap();
  for (SafetyLabel& l : m.labels)
    if (l != SafetyLabel::kUnexamined) l = SafetyLabel::kUnknown;
  ImageLabelScore s;
  ASSERT_EQ(scoreAgainstImageLabels(boxLabels(), boxDisparity(), downCamera(), downPose(), m,
                                    LabelScoringConfig(), &s),
            "");
  EXPECT_EQ(s.truth_cells, 358);
  EXPECT_EQ(s.covered_cells, 0);
  EXPECT_DOUBLE_EQ(s.coverage(), 0.0);
  EXPECT_EQ(s.exact.classified(), 0u);  // no error either: coverage is what tells
  EXPECT_DOUBLE_EQ(s.classes[static_cast<int>(ImageLabel::kFloor)].recall(), 0.0);
  EXPECT_DOUBLE_EQ(s.classes[static_cast<int>(ImageLabel::kObstacle)].recall(), 0.0);
}

TEST(ScoreAgainstImageLabels, DropOffIsHitByNonGroundOrUnknown) {
  ImageLabels l;
  ASSERT_EQ(parseImageLabels("size 100 100\nfloor 0,0 100,0 100,100 0,100\n"
                             "drop_off 38,38 62,38 62,62 38,62\n",  // cells -2..2 both ways
                             &l),
            "");
  cv::Mat img;
  ASSERT_EQ(rasteriseImageLabels(l, &img), "");
  cv::Mat disparity(kSide, kSide, CV_32F, cv::Scalar(5.0f));
  SafetyMap m = levelMap();
  m.labels[m.index(0, 0)] = SafetyLabel::kNonGround;
  m.labels[m.index(1, 0)] = SafetyLabel::kUnknown;
  ImageLabelScore s;
  ASSERT_EQ(scoreAgainstImageLabels(img, disparity, downCamera(), downPose(), m,
                                    LabelScoringConfig(), &s),
            "");
  const LabelClassScore& d = s.classes[static_cast<int>(ImageLabel::kDropOff)];
  EXPECT_EQ(d.cells, 25);
  EXPECT_EQ(d.hits, 2);
  EXPECT_EQ(d.map_safe, 23);
  EXPECT_EQ(s.exact.tp, 1u);
  EXPECT_EQ(s.exact.fn, 23u);
}

TEST(ScoreAgainstImageLabels, TiesAndTooFewVotesGiveNoTruth) {
  // Cell (0, 0) is pixels u 48..52, v 48..52. Obstacle on u 48..49 (10 votes), floor on u 50..52
  // (15): floor. Cell (1, 0) is u 53..57: obstacle on u 53..55 for rows 48..52 (15), floor 10:
  // obstacle. Cell (0, 1) is v 43..47: drop_off on a 5 x 2 block, overhang on another 5 x 2 block,
  // floor on the last row: 10 / 10 / 5: a tie.
  ImageLabels l;
  ASSERT_EQ(parseImageLabels("size 100 100\nfloor 0,0 100,0 100,100 0,100\n"
                             "obstacle 48,48 49,48 49,52 48,52\n"
                             "obstacle 53,48 55,48 55,52 53,52\n"
                             "drop_off 48,43 52,43 52,44 48,44\n"
                             "overhang 48,45 52,45 52,46 48,46\n",
                             &l),
            "");
  cv::Mat img;
  ASSERT_EQ(rasteriseImageLabels(l, &img), "");
  cv::Mat disparity(kSide, kSide, CV_32F, cv::Scalar(5.0f));
  const SafetyMap m = levelMap();
  ImageLabelScore s;
  ASSERT_EQ(scoreAgainstImageLabels(img, disparity, downCamera(), downPose(), m,
                                    LabelScoringConfig(), &s),
            "");
  EXPECT_EQ(s.truth[m.index(0, 0)], ImageLabel::kFloor);
  EXPECT_EQ(s.truth[m.index(1, 0)], ImageLabel::kObstacle);
  EXPECT_EQ(s.truth[m.index(0, 1)], ImageLabel::kNone);
  EXPECT_EQ(s.cells_tied, 1);

  // min_pixels above some cells' votes: column 10 is 2 pixels wide and row -10 2 pixels high
  // (10 votes each, 4 in their corner), column -10 and row 10 are 3 pixels (15 votes, 9 in their
  // corner (-10, 10), 6 in (10, 10) and (-10, -10)); every other cell has 25.
  LabelScoringConfig c;
  c.min_pixels = 11;
  ASSERT_EQ(scoreAgainstImageLabels(img, disparity, downCamera(), downPose(), m, c, &s), "");
  EXPECT_EQ(s.cells_too_few_votes, 21 + 20 + 1);
  EXPECT_EQ(s.truth_cells_beyond, 0);
}

TEST(ScoreAgainstImageLabels, RejectsBadInput) {
  const cv::Mat labels = boxLabels();
  const cv::Mat disparity = boxDisparity();
  const SafetyMap m = levelMap();
  ImageLabelScore s;
  EXPECT_NE(scoreAgainstImageLabels(labels, disparity, downCamera(), downPose(), m,
                                    LabelScoringConfig(), nullptr),
            "");
  EXPECT_NE(scoreAgainstImageLabels(labels(cv::Rect(0, 0, 50, 50)).clone(), disparity, downCamera(),
                                    downPose(), m, LabelScoringConfig(), &s),
            "");
  cv::Mat d64;
  disparity.convertTo(d64, CV_64F);
  EXPECT_NE(
      scoreAgainstImageLabels(labels, d64, downCamera(), downPose(), m, LabelScoringConfig(), &s),
      "");
  cv::Mat bad = labels.clone();
  bad.at<std::uint8_t>(3, 3) = 9;
  EXPECT_NE(scoreAgainstImageLabels(bad, disparity, downCamera(), downPose(), m,
                                    LabelScoringConfig(), &s),
            "");
  SafetyMap broken = m;
  broken.labels.pop_back();
  EXPECT_NE(scoreAgainstImageLabels(labels, disparity, downCamera(), downPose(), broken,
                                    LabelScoringConfig(), &s),
            "");
  LabelScoringConfig c;
  c.min_pixels = 0;
  EXPECT_NE(c.validate(), "");
  EXPECT_NE(scoreAgainstImageLabels(labels, disparity, downCamera(), downPose(), m, c, &s), "");
  c = LabelScoringConfig();
  c.max_depth = c.min_depth;
  EXPECT_NE(c.validate(), "");
  c = LabelScoringConfig();
  c.tolerance_cells = 11;
  EXPECT_NE(c.validate(), "");
  EXPECT_EQ(LabelScoringConfig().validate(), "");
}

TEST(ScoreAgainstImageLabels, DepthRangeLimitsTheVotes) {
  // The grid keeps points with Z in [min_range, max_range]: with max_depth 1.5 m only the box top
  // (Z = 1 m) votes.
  SafetyMap m = levelMap();
  ImageLabelScore s;
  ASSERT_EQ(scoreAgainstImageLabels(boxLabels(), boxDisparity(), downCamera(), downPose(), m,
                                    LabelScoringConfig::forGrid(0.2, 1.5), &s),
            "");
  EXPECT_EQ(s.truth_cells, 2);
  EXPECT_EQ(s.exact.fn, 2u);
  EXPECT_EQ(s.classes[static_cast<int>(ImageLabel::kFloor)].pixels_voting, 0u);
  EXPECT_EQ(s.classes[static_cast<int>(ImageLabel::kFloor)].pixels_with_disparity, 9100u - 279u);
}

TEST(TruthLabelGrid, MapsClassesToSafetyLabels) {
  SafetyMap m = levelMap();
  std::vector<ImageLabel> truth(m.labels.size(), ImageLabel::kNone);
  truth[0] = ImageLabel::kFloor;
  truth[1] = ImageLabel::kOverhang;
  truth[2] = ImageLabel::kIgnore;
  const LabelGrid g = truthLabelGrid(m, truth);
  EXPECT_EQ(g.validate(), "");
  EXPECT_EQ(g.labels[0], SafetyLabel::kLevel);
  EXPECT_EQ(g.labels[1], SafetyLabel::kNonGround);
  EXPECT_EQ(g.labels[2], SafetyLabel::kUnknown);
  EXPECT_EQ(g.labels[3], SafetyLabel::kUnknown);
}

}  // namespace
}  // namespace stereo_safety_map
