// Field lists of the disparity pipeline and of the other papers' parts (config_fields.h): 002's
// disparity filters and 2D occupancy grid, 003's obstacle detector, 001's laser grid and hybrid
// map. A new parameter of one of them is one add() line here.
#include "stereo_safety_map/core/config_fields.h"

#include <sstream>

namespace stereo_safety_map {

namespace {

using D = DisparityPipelineConfig;
constexpr uint32_t kMatcher = DisparityLevel::kMatcher;
constexpr uint32_t kFilter = DisparityLevel::kFilter;

// Core name (DisparityPipelineConfig::validate()) -> parameter name. Longest names first, so that
// "texture.window_size" is replaced before a shorter name could match inside it.
const std::pair<const char*, const char*> kCoreToParameter[] = {
    {"uniqueness.max_normalized_cost", "uniqueness_max_normalized_cost"},
    {"uniqueness.uniqueness_ratio", "uniqueness_ratio"},
    {"texture.log_sigma", "texture_log_sigma"},
    {"texture.window_size", "texture_window_size"},
    {"texture.min_energy", "texture_min_energy"},
    {"left_right.max_difference", "left_right_max_difference"},
    {"neighbour_consistency.window_radius", "neighbour_window_radius"},
    {"neighbour_consistency.max_difference", "neighbour_max_difference"},
    {"neighbour_consistency.min_agreeing_fraction", "neighbour_min_agreeing_fraction"},
    {"spike_removal.max_difference", "spike_max_difference"},
    {"spike_removal.min_region_size", "spike_min_region_size"},
};

// Range checks; the first failure wins. The ranges are those of cfg/Disparity.cfg.
class RangeCheck {
 public:
  template <typename T>
  void closed(const char* name, T value, T lo, T hi) {
    if (!error_.empty()) return;
    if (!(value >= lo && value <= hi)) set(name, value, "[", lo, hi, "]");
  }
  void openClosed(const char* name, double value, double lo, double hi) {
    if (!error_.empty()) return;
    if (!(value > lo && value <= hi)) set(name, value, "(", lo, hi, "]");
  }
  void fail(const std::string& message) {
    if (error_.empty()) error_ = message;
  }
  const std::string& error() const { return error_; }

 private:
  template <typename T>
  void set(const char* name, T value, const char* open, T lo, T hi, const char* close) {
    std::ostringstream os;
    os << name << " = " << value << " must be in " << open << lo << ", " << hi << close;
    error_ = os.str();
  }
  std::string error_;
};

ParamFieldList<D> makeDisparityFields() {
  ParamFieldList<D> l;
  l.section("Matcher");
  l.addAccessor<std::string>(
       "matcher", [](const D& c) { return std::string(matcherName(c.matcher)); },
       [](D* c, const std::string& v) -> std::string {
         if (matcherFromName(v, &c->matcher)) return "";
         return "matcher = '" + v + "' must be 'bm' (StereoBM) or 'sgbm' (StereoSGBM)";
       })
      .oneOf({"bm", "sgbm"})
      .live(kMatcher)
      .doc(
          "OpenCV StereoBM (SAD block matching, as 002 Sec. 2.2) or StereoSGBM (denser, "
          "slower).");
  l.add("min_disparity", &D::min_disparity)
      .closed(0, 256)
      .unit("px")
      .live(kMatcher)
      .doc("smallest disparity searched.");
  l.add("num_disparities", &D::num_disparities)
      .closed(16, 256)
      .rangeText("multiple of 16 in [16, 256]")
      .unit("px")
      .live(kMatcher)
      .doc(
          "disparities searched; the nearest depth seen is f B / (min_disparity + "
          "num_disparities).");
  // A texture window that follows the block size (texture_window_size 0) follows it here too.
  l.addAccessor<int>(
       "block_size", [](const D& c) { return c.block_size; },
       [](D* c, const int& v) {
         if (c->texture.window_size == c->block_size) c->texture.window_size = v;
         c->block_size = v;
         return std::string();
       })
      .closed(1, 255)
      .rangeText("odd, [5, 255] bm / [1, 255] sgbm")
      .unit("px")
      .live(kMatcher)
      .doc("matching window side.");
  l.add("pre_filter_cap", &D::pre_filter_cap)
      .closed(1, 63)
      .live(kMatcher)
      .doc("clip of the matcher's x-derivative pre-filter.");
  l.add("bm_texture_threshold", &D::bm_texture_threshold)
      .closed(0, 10000)
      .live(kMatcher)
      .doc(
          "OpenCV's own texture test (bm only), 0 = off: texture validation is 002's version of "
          "it.");
  l.add("speckle_window_size", &D::speckle_window_size)
      .closed(0, 10000)
      .unit("px")
      .live(kMatcher)
      .doc(
          "OpenCV's speckle filter inside the matcher, 0 = off: spike removal is 002's version "
          "of it.");
  l.add("speckle_range", &D::speckle_range)
      .closed(0, 64)
      .unit("px")
      .live(kMatcher)
      .doc("disparity continuity of that speckle filter.");
  l.add("sgbm_p1", &D::sgbm_p1)
      .closed(0, 1000000)
      .live(kMatcher)
      .doc("SGBM smoothness penalty P1, 0 = 8 block_size^2.");
  l.add("sgbm_p2", &D::sgbm_p2)
      .closed(0, 1000000)
      .live(kMatcher)
      .doc("SGBM smoothness penalty P2, 0 = 32 block_size^2; > sgbm_p1 when both are set.");
  l.add("sgbm_three_way", &D::sgbm_three_way)
      .live(kMatcher)
      .doc("SGBM in MODE_SGBM_3WAY (faster) instead of MODE_SGBM.");

  l.section("Post-filters (run in this order)");
  l.add("enable_uniqueness", &D::enable_uniqueness)
      .live(kMatcher)
      .doc(
          "quality-of-match test (002 Sec. 2.2), inside the matcher (OpenCV's uniquenessRatio, "
          "the only place that sees the matching costs).");
  l.add("uniqueness_ratio", &D::uniqueness, &MatchUniquenessConfig::uniqueness_ratio)
      .closed(0, 100)
      .unit("%")
      .live(kMatcher)
      .doc(
          "the best cost must beat every other (but its direct neighbours) by this much (002 "
          "Sec. 2.2; OpenCV's customary 15).");
  l.add("enable_texture", &D::enable_texture)
      .live(kFilter)
      .doc("sufficient-texture test: window mean of |LoG| of the left image (002 Sec. 2.2).");
  l.add("texture_log_sigma", &D::texture, &TextureValidationConfig::log_sigma)
      .openClosed(0, 10)
      .unit("px")
      .live(kFilter)
      .doc("Gaussian sigma of the LoG.");
  l.addAccessor<int>(
       "texture_window_size", [](const D& c) { return textureWindowParameter(c); },
       [](D* c, const int& v) {
         c->texture.window_size = v == 0 ? c->block_size : v;
         return std::string();
       })
      .closed(0, 255)
      .rangeText("0 = block_size, or odd in [1, 255]")
      .unit("px")
      .live(kFilter)
      .doc("window over which |LoG| is averaged (002: the matching window).");
  l.add("texture_min_energy", &D::texture, &TextureValidationConfig::min_energy)
      .closed(0, 1000)
      .unit("grey levels")
      .live(kFilter)
      .doc(
          "windows whose mean |LoG| is below this are invalid; sensor noise of 3 grey levels "
          "scores ~0.8.");
  l.add("enable_left_right", &D::enable_left_right)
      .live(kFilter)
      .doc(
          "left-right consistency: match right-to-left as well and keep a pixel only when both "
          "agree (002 Sec. 4.1, ref. [7]).");
  l.add("left_right_max_difference", &D::left_right, &LeftRightCheckConfig::max_difference)
      .closed(0, 256)
      .unit("px")
      .live(kFilter)
      .doc("largest |d_L(x) - d_R(x - d_L(x))| kept.");
  l.add("left_right_reject_if_right_invalid", &D::left_right,
        &LeftRightCheckConfig::reject_if_right_invalid)
      .live(kFilter)
      .doc("remove a pixel whose right-to-left match is missing.");
  l.addAccessor<std::string>(
       "left_right_mode",
       [](const D& c) { return std::string(leftRightModeName(c.left_right_mode)); },
       [](D* c, const std::string& v) -> std::string {
         if (leftRightModeFromName(v, &c->left_right_mode)) return "";
         return "left_right_mode = '" + v + "' must be 'full', 'half' or 'opencv'";
       })
      .oneOf({"full", "half", "opencv"})
      .live(kMatcher)
      .doc(
          "full: a right-to-left match of its own (for sgbm a second full matcher); half: that "
          "match on the half-size pair, its disparities doubled (~1/8 of the work, not bit for "
          "bit full); opencv: OpenCV's check inside the left matcher (disp12MaxDiff = "
          "floor(max_difference)), no second match, weaker: keeps pixels whose right pixel no "
          "left winner claimed (ours, issue 18; docs/performance.md).");
  l.add("parallel_left_right", &D::parallel_left_right)
      .doc(
          "run the right-to-left matcher on a second thread beside the left-to-right one: the "
          "same disparities and CPU time, lower latency when a core is free (ours, "
          "docs/performance.md).");
  l.add("enable_neighbour_consistency", &D::enable_neighbour_consistency)
      .live(kFilter)
      .doc("remove readings unlike their neighbours (000 Sec. III).");
  l.add("neighbour_window_radius", &D::neighbour_consistency,
        &NeighbourConsistencyConfig::window_radius)
      .closed(1, 5)
      .live(kFilter)
      .doc("window radius r, (2r + 1)^2 pixels.");
  l.add("neighbour_max_difference", &D::neighbour_consistency,
        &NeighbourConsistencyConfig::max_difference)
      .closed(0, 256)
      .unit("px")
      .live(kFilter)
      .doc("a neighbour within this agrees.");
  l.add("neighbour_min_agreeing_fraction", &D::neighbour_consistency,
        &NeighbourConsistencyConfig::min_agreeing_fraction)
      .openClosed(0, 1)
      .live(kFilter)
      .doc("fraction of the valid neighbours that must agree; 0.25 keeps one-pixel-wide lines.");
  l.add("neighbour_remove_isolated", &D::neighbour_consistency,
        &NeighbourConsistencyConfig::remove_isolated)
      .live(kFilter)
      .doc("remove a pixel without any valid neighbour.");
  l.add("enable_spike_removal", &D::enable_spike_removal)
      .live(kFilter)
      .doc("spike removal by disparity-surface segmentation (002 Sec. 4.2).");
  l.add("spike_max_difference", &D::spike_removal, &SpikeRemovalConfig::max_difference)
      .openClosed(0, 256)
      .unit("px")
      .live(kFilter)
      .doc("4-neighbours this close join one surface (002 Sec. 4.2: 1).");
  l.add("spike_min_region_size", &D::spike_removal, &SpikeRemovalConfig::min_region_size)
      .closed(1, 1000000)
      .unit("px")
      .live(kFilter)
      .doc(
          "smaller surfaces are removed (002 gives none; scale with the image area; 200 leaves "
          "low-texture ground too sparse).");
  l.add("coarse_fill_levels", &D::coarse_fill_levels)
      .closed(0, 3)
      .live(kFilter)
      .doc(
          "multi-scale fill: 0 = off; k matches the pair shrunk 2x (with k - 1 coarser levels) "
          "through every step above and fills, with its doubled disparities, the pixels the "
          "full-resolution output left invalid, unless a valid reading in the 2 x 2 block "
          "disagrees or one within block_size px is nearer (pale floors; 000 Sec. III's matcher "
          "was multi-scale, the rule is ours).");
  l.add("coarse_fill_max_depth", &D::coarse_fill_max_depth)
      .closed(0, 100)
      .unit("m")
      .live(kFilter)
      .doc(
          "the coarse fill's reach: coarse readings farther from the camera fill nothing, since "
          "the coarse window smooths a step's height over its rows (ours; 0 = any range).");
  l.setValidator([](const D& c) { return validateDisparityParameters(c); });
  return l;
}

using O = ObstacleDetectionConfig;

ParamFieldList<O> makeObstacleFields() {
  ParamFieldList<O> l;
  l.section("Definition 1 (003 Sec. 2)");
  l.add("height_threshold", &O::height_threshold)
      .above(0)
      .unit("m")
      .doc(
          "H_T, the smallest rise that is an obstacle: the highest step the wheelchair rolls "
          "over (000's h_T; 003 gives no value).");
  l.add("max_height", &O::max_height)
      .above(0)
      .rangeText("> height_threshold")
      .unit("m")
      .doc(
          "H_max, the largest height difference of a compatible pair: window size and obstacle "
          "separation (003 Sec. 3-4).");
  l.add("slope_threshold_deg", &O::slope_threshold_deg)
      .open(0, 90)
      .unit("deg")
      .doc("theta_T: the line joining a compatible pair is steeper than this (003 Def. 1).");

  l.section("Stereo noise margin (ours, 001 Sec. 4.1)");
  l.add("noise_sigmas", &O::noise_sigmas)
      .closed(0, 10)
      .doc(
          "k: Definition 1 must still hold with both points moved k sigma of their stereo range "
          "error along their rays, the least steep way; 0 = off (003's constants; ours).");
  l.add("disparity_sigma", &O::disparity_sigma)
      .openClosed(0, 10)
      .unit("px")
      .doc("sigma_d of the noise margin: the disparity error's standard deviation (001 Sec. 4.1).");

  l.section("Search (003 Sec. 2, 4.1)");
  l.add("exhaustive_search", &O::exhaustive_search)
      .doc(
          "true = OD Algorithm 2 verbatim (every pair of the window; ~60x slower); false = "
          "early exit at the first partner (the same obstacle points, labels from the links "
          "found plus surface links; ours).");
  l.add("search_foot_points", &O::search_foot_points)
      .doc("early exit: also find the feet (lower ends), as the paper marks them.");
  l.add("sample_spacing", &O::sample_spacing)
      .atLeast(0)
      .unit("m")
      .doc("early exit: spacing of the tested pixels at the point's depth, 0 = all (ours).");
  l.add("max_candidates_per_pixel", &O::max_candidates_per_pixel)
      .atLeast(0)
      .doc("early exit: most pixels tested per window (linear time), 0 = no bound (ours).");
  l.add("surface_link_distance", &O::surface_link_distance)
      .atLeast(0)
      .unit("m")
      .doc("early exit: raised image neighbours this close in 3D share a label, 0 = off (ours).");
  l.add("surface_link_pixels", &O::surface_link_pixels)
      .atLeast(0)
      .doc("early exit: ... or this close in pixel footprints Z / f (ours).");

  l.section("Segmentation and rules (003 Sec. 3, 5)");
  l.add("segment", &O::segment)
      .doc("label obstacles (OS Algorithm 2); false: obstacle points only.");
  l.add("reject_false_obstacles", &O::reject_false_obstacles)
      .doc("apply the rules below (003 Sec. 5).");
  l.add("min_avg_slope_deg", &O::min_avg_slope_deg)
      .closed(0, 90)
      .unit("deg")
      .doc("reject when the average slope is lower (003 Sec. 5's example, 2.5).");
  l.add("min_max_slope_deg", &O::min_max_slope_deg)
      .closed(0, 90)
      .unit("deg")
      .doc("reject when the maximum slope is lower (003 Sec. 5's example, 5.0).");
  l.add("min_avg_height", &O::min_avg_height)
      .atLeast(0)
      .unit("m")
      .doc(
          "reject when the mean height above the obstacle's ground is lower, 0 = off (no value "
          "in 003).");
  l.add("min_max_height", &O::min_max_height)
      .atLeast(0)
      .unit("m")
      .doc(
          "reject when the top is lower above the obstacle's ground, 0 = off (no value in 003; "
          "README, \"Obstacle cue\").");
  l.add("min_bbox_perimeter", &O::min_bbox_perimeter)
      .atLeast(0)
      .unit("m")
      .doc(
          "reject when 4 (dx + dy + dz) of the 3D box is smaller, 0 = off (003 Sec. 5 names the "
          "measure, no value).");
  l.add("min_volume", &O::min_volume)
      .atLeast(0)
      .unit("m^3")
      .doc(
          "reject when (larger horizontal side)^2 x height is smaller: stereo blobs (003 Sec. 5 "
          "\"small bounding volume\").");
  l.setValidator([](const O& c) { return c.validate(); });
  return l;
}

using G = OccupancyGrid2DConfig;

ParamFieldList<G> makeOccupancyFields() {
  ParamFieldList<G> l;
  l.section("Grid (002 Sec. 3)");
  l.add("resolution", &G::resolution)
      .openClosed(0, 10)
      .unit("m")
      .doc("cell side (002 gives none; the safety map's l_v, so that the grids share cells).");
  l.add("size_x", &G::size_x)
      .above(0)
      .rangeText("[resolution, 20000 resolution]")
      .unit("m")
      .doc("window extent along x (not in 002: a robot-local window).");
  l.add("size_y", &G::size_y)
      .above(0)
      .rangeText("[resolution, 20000 resolution]")
      .unit("m")
      .doc("window extent along y.");
  l.add("k", &G::k).closed(1, 255).doc("K of the +/-K update (002 Sec. 3.4: 20).");
  l.add("free_threshold", &G::free_threshold)
      .closed(0, 128)
      .doc(
          "G below this is free; at most 128 so that a never-seen cell is not free (002 Sec. "
          "3.4: 50).");
  l.add("occupied_threshold", &G::occupied_threshold)
      .closed(128, 255)
      .doc(
          "G above this is occupied; at least 128 so that a never-seen cell is not occupied (002 "
          "Sec. 3.4: 150).");
  l.add("disparity_half_width", &G::disparity_half_width)
      .openClosed(0, 10)
      .unit("px")
      .doc("the region of uncertainty spans Z(d + h) .. Z(d - h) (002 Eq. (1): 0.5).");
  l.add("floor_clearance", &G::floor_clearance)
      .rangeText("finite, < robot_height")
      .unit("m")
      .doc(
          "lower edge of the height band above the floor; our tilted camera would otherwise see "
          "the floor as every column's closest point (not in 002).");
  l.add("robot_height", &G::robot_height)
      .rangeText("> floor_clearance")
      .unit("m")
      .doc("upper edge of the band: the robot passes under anything higher (002 Sec. 3.3).");
  l.add("accuracy_preservation", &G::accuracy_preservation)
      .doc(
          "a reading whose region already holds a cell leaning occupied from a higher disparity "
          "is not applied (002 Sec. 4.3).");
  l.setValidator([](const G& c) { return c.validate(); });
  return l;
}

using LG = LaserGridConfig;

ParamFieldList<LG> makeLaserFields() {
  ParamFieldList<LG> l;
  l.section("Laser grid (001 Sec. 3)");
  l.add("resolution", &LG::resolution)
      .above(0)
      .unit("m")
      .doc(
          "laser cell side; use the safety map's `voxel_size` so that cells coincide (otherwise "
          "the laser grid is sampled at each cell's centre).");
  l.add("log_odds_hit", &LG::log_odds_hit)
      .above(0)
      .doc("added to a beam's return cell, logit(0.7).");
  l.add("log_odds_miss", &LG::log_odds_miss)
      .below(0)
      .doc("added to each cell a beam crosses, logit(0.4).");
  l.add("log_odds_min", &LG::log_odds_min)
      .rangeText("<= free_threshold")
      .doc("lower clamp; lets a departed obstacle clear within a few scans.");
  l.add("log_odds_max", &LG::log_odds_max).rangeText(">= occupied_threshold").doc("upper clamp.");
  l.add("occupied_threshold", &LG::occupied_threshold)
      .above(0)
      .rangeText("(0, log_odds_max]")
      .doc("a cell is Occupied at log-odds >= this: one hit.");
  l.add("free_threshold", &LG::free_threshold)
      .below(0)
      .rangeText("[log_odds_min, 0)")
      .doc("a cell is Free at log-odds <= this: one miss.");
  l.add("clear_no_return", &LG::clear_no_return)
      .doc(
          "beams without a return (+inf or >= range_max, REP 117) clear free space to "
          "range_max.");
  l.setValidator([](const LG& c) { return c.validate(); });
  return l;
}

using H = HybridSafetyMapConfig;

ParamFieldList<H> makeHybridFields() {
  ParamFieldList<H> l;
  l.section("Combination (001 Sec. 2.1, 5)");
  l.add("detect_narrow_passages", &H::detect_narrow_passages)
      .doc(
          "Safe cells in passages narrower than min_passage_width become Caution (001 Sec. 2.1 "
          "\"narrow regions\").");
  l.add("min_passage_width", &H::min_passage_width)
      .openClosed(0, 100)
      .unit("m")
      .doc("36 in, the ADA minimum clear width for a wheelchair (001 cites the ADA standards).");
  l.add("drop_off_edges_are_caution", &H::drop_off_edges_are_caution)
      .doc(
          "000's potential drop-off edges are Caution (000 Sec. VI: they need further "
          "observation) when drop_off_edges_are_hazard is off.");
  l.add("drop_off_edges_are_hazard", &H::drop_off_edges_are_hazard)
      .doc(
          "000's potential drop-off edges are Hazard, lethal (ours: Caution reads as free to a "
          "trinary costmap; false = Caution, 000 Sec. VI).");
  l.add("laser_free_required_for_safe", &H::laser_free_required_for_safe)
      .doc("Level / Inclined need laser Free to be Safe / Caution (001 Sec. 5 read literally).");
  l.add("laser_free_vision_unknown_is_safe", &H::laser_free_vision_unknown_is_safe)
      .doc(
          "laser Free with no vision information is Safe; false: Unknown, as the laser cannot "
          "see drop-offs (001 Sec. 1).");
  l.section("Value table of `hybrid_map`");
  l.add("hazard_cost", &H::hazard_cost)
      .closed(1, 100)
      .doc(
          "value of Hazard cells; 100 = lethal (001 Sec. 2.1: overhangs, drop-offs, steep "
          "inclines). Below 100 a costmap needs trinary_costmap: false, or hazards read as free.");
  l.add("caution_cost", &H::caution_cost)
      .closed(0, 99)
      .doc("value of Caution cells, below lethal (001 Sec. 2.1: inclines, narrow regions).");
  l.setValidator([](const H& c) { return c.validate(); });
  return l;
}

}  // namespace

const char* matcherName(StereoMatcherType type) {
  return type == StereoMatcherType::kSemiGlobal ? "sgbm" : "bm";
}

bool matcherFromName(const std::string& name, StereoMatcherType* type) {
  if (name == "bm") {
    *type = StereoMatcherType::kBlockMatching;
  } else if (name == "sgbm") {
    *type = StereoMatcherType::kSemiGlobal;
  } else {
    return false;
  }
  return true;
}

const char* leftRightModeName(LeftRightMode mode) {
  switch (mode) {
    case LeftRightMode::kOpenCV:
      return "opencv";
    case LeftRightMode::kHalfResolution:
      return "half";
    case LeftRightMode::kFull:
      break;
  }
  return "full";
}

bool leftRightModeFromName(const std::string& name, LeftRightMode* mode) {
  if (name == "full") {
    *mode = LeftRightMode::kFull;
  } else if (name == "opencv") {
    *mode = LeftRightMode::kOpenCV;
  } else if (name == "half") {
    *mode = LeftRightMode::kHalfResolution;
  } else {
    return false;
  }
  return true;
}

int textureWindowParameter(const DisparityPipelineConfig& c) {
  return c.texture.window_size == c.block_size ? 0 : c.texture.window_size;
}

std::string toParameterNames(const std::string& core_message) {
  std::string s = core_message;
  for (const auto& names : kCoreToParameter) {
    const std::string from = names.first;
    for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at)) {
      s.replace(at, from.size(), names.second);
      at += std::char_traits<char>::length(names.second);
    }
  }
  return s;
}

std::string validateDisparityParameters(const DisparityPipelineConfig& c) {
  const int texture_window_param = textureWindowParameter(c);
  RangeCheck r;
  r.closed("min_disparity", c.min_disparity, 0, 256);
  if (r.error().empty() &&
      (c.num_disparities < 16 || c.num_disparities > 256 || c.num_disparities % 16 != 0)) {
    r.fail("num_disparities = " + std::to_string(c.num_disparities) +
           " must be a multiple of 16 in [16, 256]");
  }
  const int min_block = c.matcher == StereoMatcherType::kBlockMatching ? 5 : 1;
  if (r.error().empty() &&
      (c.block_size % 2 == 0 || c.block_size < min_block || c.block_size > 255)) {
    r.fail("block_size = " + std::to_string(c.block_size) + " must be odd and in [" +
           std::to_string(min_block) + ", 255]" +
           (min_block == 5 ? " for matcher bm" : " for matcher sgbm"));
  }
  r.closed("pre_filter_cap", c.pre_filter_cap, 1, 63);
  r.closed("bm_texture_threshold", c.bm_texture_threshold, 0, 10000);
  r.closed("speckle_window_size", c.speckle_window_size, 0, 10000);
  r.closed("speckle_range", c.speckle_range, 0, 64);
  r.closed("sgbm_p1", c.sgbm_p1, 0, 1000000);
  r.closed("sgbm_p2", c.sgbm_p2, 0, 1000000);
  r.closed("uniqueness_ratio", c.uniqueness.uniqueness_ratio, 0, 100);
  r.openClosed("texture_log_sigma", c.texture.log_sigma, 0.0, 10.0);
  if (r.error().empty() && texture_window_param != 0 &&
      (texture_window_param % 2 == 0 || texture_window_param < 1 || texture_window_param > 255)) {
    r.fail("texture_window_size = " + std::to_string(texture_window_param) +
           " must be 0 (= block_size) or odd and in [1, 255]");
  }
  r.closed("texture_min_energy", c.texture.min_energy, 0.0, 1000.0);
  r.closed("left_right_max_difference", c.left_right.max_difference, 0.0, 256.0);
  r.closed("neighbour_window_radius", c.neighbour_consistency.window_radius, 1, 5);
  r.closed("neighbour_max_difference", c.neighbour_consistency.max_difference, 0.0, 256.0);
  r.openClosed("neighbour_min_agreeing_fraction", c.neighbour_consistency.min_agreeing_fraction,
               0.0, 1.0);
  r.openClosed("spike_max_difference", c.spike_removal.max_difference, 0.0, 256.0);
  r.closed("spike_min_region_size", c.spike_removal.min_region_size, 1, 1000000);
  r.closed("coarse_fill_levels", c.coarse_fill_levels, 0, 3);
  r.closed("coarse_fill_max_depth", c.coarse_fill_max_depth, 0.0, 100.0);
  if (!r.error().empty()) return r.error();
  return toParameterNames(c.validate());
}

const ParamFieldList<DisparityPipelineConfig>& disparityPipelineFields() {
  static const ParamFieldList<DisparityPipelineConfig> list = makeDisparityFields();
  return list;
}

const ParamFieldList<ObstacleDetectionConfig>& obstacleDetectionFields() {
  static const ParamFieldList<ObstacleDetectionConfig> list = makeObstacleFields();
  return list;
}

const ParamFieldList<OccupancyGrid2DConfig>& occupancyGrid2DFields() {
  static const ParamFieldList<OccupancyGrid2DConfig> list = makeOccupancyFields();
  return list;
}

const ParamFieldList<LaserGridConfig>& laserGridFields() {
  static const ParamFieldList<LaserGridConfig> list = makeLaserFields();
  return list;
}

const ParamFieldList<HybridSafetyMapConfig>& hybridSafetyMapFields() {
  static const ParamFieldList<HybridSafetyMapConfig> list = makeHybridFields();
  return list;
}

}  // namespace stereo_safety_map
