// The safety map's core parameters: paper 000's mapper, 001's landmark filter, and what the
// offline tools read (config_fields.h). A new core parameter of the safety map is one add() line
// here (DEVELOPERS.md, "How to add a parameter").
#include "stereo_safety_map/core/config_fields.h"

namespace stereo_safety_map {

namespace {

using M = SafetyMapperConfig;
using L = LandmarkStreamConfig;
constexpr uint32_t kStage = SafetyMapLevel::kStage;
constexpr uint32_t kGrid = SafetyMapLevel::kGrid;

// The parts' validate() unprefixed (as each part's reader reported them), then the mapper's
// own; PlaneFitConfig names vertical_margin, the parameter is plane_vertical_margin.
std::string mapperParameterError(const M& c) {
  std::string err;
  if (!(err = c.grid.validate()).empty()) return err;
  if (!(err = c.height_map.validate()).empty()) return err;
  if (!(err = c.segmentation.validate()).empty()) return err;
  if (!(err = c.plane_fit.validate()).empty()) {
    const std::string core = "vertical_margin";
    if (err.compare(0, core.size(), core) == 0) err = "plane_" + err;
    return err;
  }
  if (!(err = c.labelling.validate()).empty()) return err;
  return c.validate();
}

ParamFieldList<M> makeMapperFields() {
  ParamFieldList<M> l;
  l.section("Voxel grid (000 Sec. IV)");
  l.add("voxel_size", &M::grid, &VoxelGridConfig::voxel_size)
      .above(0)
      .unit("m")
      .doc("l_v, the voxel side (000 Sec. IV: 0.1 m).");
  l.add("size_x", &M::grid, &VoxelGridConfig::size_x)
      .above(0)
      .rangeText(">= voxel_size")
      .unit("m")
      .doc("grid extent along x, at most the core's voxel limit (000 Sec. VII-D: 10 x 10 x 3 m).");
  l.add("size_y", &M::grid, &VoxelGridConfig::size_y)
      .above(0)
      .rangeText(">= voxel_size")
      .unit("m")
      .doc("grid extent along y (000 Sec. VII-D).");
  l.add("size_z", &M::grid, &VoxelGridConfig::size_z)
      .above(0)
      .rangeText(">= voxel_size")
      .unit("m")
      .doc("grid extent along z (000 Sec. VII-D).");
  l.add("z_below_robot", &M::grid, &VoxelGridConfig::z_below_robot)
      .atLeast(0)
      .rangeText("[0, size_z]")
      .unit("m")
      .doc("grid depth below the robot's base; drops down to it stay inside the grid (ours).");
  l.add("incr_high", &M::grid, &VoxelGridConfig::incr_high)
      .closed(0, 32767)
      .live(kGrid)
      .doc("incr_H, log-odds added to the voxel a point falls in (000 Sec. IV: 10).");
  l.add("incr_low", &M::grid, &VoxelGridConfig::incr_low)
      .closed(0, 32767)
      .live(kGrid)
      .doc("incr_L, log-odds added to its fore and aft neighbours on the ray (000 Sec. IV: 4).");
  l.add("incr_low_fore", &M::grid, &VoxelGridConfig::incr_low_fore)
      .closed(-1, 32767)
      .live(kGrid)
      .doc(
          "incr_L of the fore neighbour alone: for a floor point seen from above it is the voxel "
          "above the floor (ours; -1 = incr_low, 000 Sec. IV).");
  l.add("neighbour_sigmas", &M::grid, &VoxelGridConfig::neighbour_sigmas)
      .closed(0, 100)
      .live(kGrid)
      .doc(
          "incr_L only where the point's range error reaches: a fore / aft neighbour whose face "
          "is farther along the ray than this many sigma_Z = Z^2 sigma_d / (f b) (001 Sec. "
          "4.1) gets nothing (ours; 0 = 000 Sec. IV, always incr_L).");
  l.add("disparity_sigma", &M::grid, &VoxelGridConfig::disparity_sigma)
      .openClosed(0, 10)
      .live(kGrid)
      .doc("sigma_d [px] of neighbour_sigmas (001 Sec. 4.1; ours).");
  l.add("decr", &M::grid, &VoxelGridConfig::decr)
      .closed(0, 32767)
      .live(kGrid)
      .doc(
          "decr, log-odds subtracted from each voxel between the fore neighbour and the camera "
          "(000 Sec. IV; Sec. VII-A evaluates 1, 3, 5).");
  l.add("occ_threshold", &M::grid, &VoxelGridConfig::occ_threshold)
      .closed(1, 32767)
      .rangeText("[1, lop_max]")
      .live(kGrid)
      .doc("occ_t, a voxel is occupied at log-odds >= occ_t (000 Sec. IV: 100).");
  l.add("lop_min", &M::grid, &VoxelGridConfig::lop_min)
      .closed(-32768, -1)
      .doc("lower log-odds clamp, so that the map can change its mind (ours).");
  l.add("lop_max", &M::grid, &VoxelGridConfig::lop_max)
      .closed(1, 32767)
      .doc("upper log-odds clamp (ours).");
  l.add("point_list_capacity", &M::grid, &VoxelGridConfig::point_list_capacity)
      .closed(1, 255)
      .doc(
          "points kept per voxel, closest to the camera first (000 Sec. IV: \"fixed size\", no "
          "value).");
  l.add("max_range", &M::grid, &VoxelGridConfig::max_range)
      .above(0)
      .rangeText("> min_range")
      .unit("m")
      .doc("points farther from the camera are ignored (ours).");
  l.add("min_range", &M::grid, &VoxelGridConfig::min_range)
      .atLeast(0)
      .unit("m")
      .doc("points closer to the camera are ignored (ours).");

  l.section("Height map and segmentation (000 Sec. V-A, Alg. 1)");
  l.add("robot_height", &M::height_map, &HeightMapConfig::robot_height)
      .openClosed(0, 100)
      .unit("m")
      .live(kStage)
      .doc("robot height above its base: the robot passes under anything higher (000 Sec. V-A).");
  l.add("observation_means", &M::height_map, &HeightMapConfig::observation_means)
      .doc(
          "column heights are the means of every point their voxels received, not of the "
          "voxels' capped closest-first point lists, which bias a floor by +-2 cm (ours; false = "
          "000 Sec. IV's lists).");
  l.add("near_view_ratio", &M::height_map, &HeightMapConfig::near_view_ratio)
      .closed(0, 100)
      .rangeText("0 or [1, 100]")
      .doc(
          "a column's highest occupied voxel that sits on another is passed over when its "
          "points' nearest observation is more than this many times as far as the voxel "
          "below's: the upper noise tail of a floor seen from afar, over the floor seen from "
          "near (ours; 0 = 000 Sec. V-A's highest voxel). 0 or [1, 100].");
  l.add("tail_share", &M::height_map, &HeightMapConfig::tail_share)
      .closed(0, 1)
      .doc(
          "a column's highest occupied voxel that sits on another is passed over when it "
          "received fewer than this share of the points of the voxel below (every point "
          "counted, not 000 Sec. IV's one per frame): a noise tail is not a surface (ours; 0 = "
          "000 Sec. V-A's highest voxel).");
  l.add("mass_heights", &M::height_map, &HeightMapConfig::mass_heights)
      .doc(
          "a column's measured surface height is the mean of every point of its top voxel and "
          "the voxels just below and above it, not of the top voxel's capped point list, which "
          "holds only the part of a surface's noise above a voxel boundary (ours; false = 000 "
          "Sec. IV-V).");
  l.add("mass_bands", &M::height_map, &HeightMapConfig::mass_bands)
      .doc(
          "with mass_heights, a column's indexed height is the voxel its measured surface lies "
          "in, within its occupied extent (ours; false = 000 Sec. V-A's highest occupied "
          "voxel).");
  l.add("sparse_edge_share", &M::height_map, &HeightMapConfig::sparse_edge_share)
      .closed(0, 1)
      .doc(
          "a column beside an unobserved one that received fewer than this share of the points "
          "of the neighbour opposite it, at that neighbour's height, is taken as not observed "
          "(Unknown): block matching's foreground fattening puts a near surface's disparity on "
          "a narrow strip of the farther surface beside it (ours, on 002 Sec. 4.1; 0 = off, "
          "000 Sec. V-A).");
  l.add("planning_radius", &M::segmentation, &GroundSegmentationConfig::planning_radius)
      .openClosed(0, 1000)
      .unit("m")
      .live(kStage)
      .doc("R_max: farther cells are Unexamined (000 Alg. 1 step 3: 4 m).");
  l.add("height_tolerance", &M::segmentation, &GroundSegmentationConfig::height_tolerance)
      .closed(0, 1000)
      .unit("voxels")
      .live(kStage)
      .doc("w_T: neighbour height difference that may start a new segment (000 Alg. 1 step 13).");
  l.add("connectivity", &M::segmentation, &GroundSegmentationConfig::connectivity)
      .oneOf({"4", "8"})
      .doc("flood-fill neighbourhood (not in the paper; 8 as the neighbourhood of 000 Sec. VI).");
  l.add("seed_radius", &M::segmentation, &GroundSegmentationConfig::seed_radius)
      .closed(0, 1000)
      .unit("m")
      .doc(
          "the camera cannot see under the chair: the robot's segment starts at the best "
          "observed cell within this radius (ours).");
  l.add("segment_islands", &M::segmentation, &GroundSegmentationConfig::segment_islands)
      .doc(
          "observed ground cut off from the robot's segment by unobserved cells becomes segments "
          "of its own, judged by Alg. 2, instead of Non-ground columns (ours; false = 000's Alg. "
          "1).");
  l.add("island_max_span", &M::segmentation, &GroundSegmentationConfig::island_max_span)
      .closed(0, 1000)
      .unit("voxels")
      .doc(
          "columns whose occupied voxels span more (faces of obstacles) never join an island "
          "segment (ours).");
  l.add("split_steps", &M::segmentation, &GroundSegmentationConfig::split_steps)
      .live(kStage)
      .doc(
          "a segment holding a step lower than a voxel (6 cm down into a sunken floor) is split "
          "where the ground heights of its columns jump, and Alg. 2 judges the step by the two "
          "sides' planes (ours; false = 000's Alg. 1).");
  l.add("split_min_step", &M::segmentation, &GroundSegmentationConfig::split_min_step)
      .openClosed(0, 10)
      .unit("m")
      .live(kStage)
      .doc(
          "split_steps: the smallest step between the two sides' local planes that splits; Alg. "
          "2's h_T decides whether it is crossable (ours).");
  l.add("split_min_cells", &M::segmentation, &GroundSegmentationConfig::split_min_cells)
      .closed(1, 100000)
      .unit("cells")
      .live(kStage)
      .doc("split_steps: fewest cells of a side; smaller parts are noise (ours).");
  l.add("footprint_radius", &M::segmentation, &GroundSegmentationConfig::footprint_radius)
      .closed(0, 5)
      .unit("m")
      .doc(
          "the robot stands on ground: unobserved cells this close to the base are ground at the "
          "base's height and seed the robot's segment (ours; 0 = 000's seed rule alone).");
  l.add("seed_on_support", &M::segmentation, &GroundSegmentationConfig::seed_on_support)
      .doc(
          "the robot's segment is seeded at the indexed height most cells within "
          "footprint_radius hold (the ground the chair stands on), not at stray columns at the "
          "base's own height beside a floor that reads a voxel high (ours; false = the seed "
          "rule alone).");
  l.add("seed_support_max_offset", &M::segmentation,
        &GroundSegmentationConfig::seed_support_max_offset)
      .closed(0, 1)
      .unit("m")
      .doc(
          "seed_on_support: a support off the base's index is taken only when its median ground "
          "height lies this close to the base's; a floor farther off the wheels is a map whose "
          "heights cannot be trusted near the robot (ours).");

  l.section("Plane fit (000 Sec. V-B)");
  l.add("min_points", &M::plane_fit, &PlaneFitConfig::min_points)
      .closed(3, 1000000)
      .doc("fewest points for a valid plane; fewer leave the segment Unknown (ours).");
  l.add("min_xy_stddev", &M::plane_fit, &PlaneFitConfig::min_xy_stddev)
      .openClosed(0, 10)
      .unit("m")
      .doc("smallest xy spread of the points; below it the plane is undetermined (ours).");
  l.add("plane_vertical_margin", &M::plane_fit, &PlaneFitConfig::vertical_margin)
      .closed(0, 3)
      .unit("voxels")
      .doc(
          "voxel layers above and below a segment whose points join its fit, so that a ramp's "
          "slope is not flattened (ours; 0 = 000 Sec. V-B; off: less robust on small noisy real "
          "patches).");
  l.add("plane_observation_means", &M::plane_fit, &PlaneFitConfig::observation_means)
      .doc(
          "each voxel's list points join its segment's plane moved in z to the mean of every "
          "point the voxel received and weighted by their number (ours; false = 000 Sec. "
          "IV-V-B's capped closest-first lists).");

  l.add("plane_mass_heights", &M::plane_fit, &PlaneFitConfig::mass_heights)
      .doc(
          "each voxel's list points join its segment's plane moved in z to the column's height "
          "from every point of the surface's voxels (mass_heights) (ours; false = 000 Sec. "
          "V-B's lists).");

  l.section("Labelling (000 Sec. VI, Alg. 2)");
  l.add("max_slope_deg", &M::labelling, &SafetyLabellingConfig::max_slope_deg)
      .open(0, 90)
      .unit("deg")
      .live(kStage)
      .doc("theta_max: steeper planes are Non-ground (000 Alg. 2 step 2: 10).");
  l.add("slope_margin_deg", &M::labelling, &SafetyLabellingConfig::slope_margin_deg)
      .closedOpen(0, 90)
      .unit("deg")
      .live(kStage)
      .doc(
          "taken off theta_max where Alg. 2 step 2 judges a plane's slope: a least-squares plane "
          "reads a ramp flatter than it is, so a plane measured within this margin of theta_max "
          "is Non-ground; at most theta_max - theta_T (ours; 0 = 000).");
  l.add("level_slope_deg", &M::labelling, &SafetyLabellingConfig::level_slope_deg)
      .closedOpen(0, 90)
      .rangeText("[0, max_slope_deg]")
      .unit("deg")
      .live(kStage)
      .doc("theta_T: safe planes steeper than this are Inclined (000 Alg. 2 step 28: 3).");
  l.add("min_segment_cells", &M::labelling, &SafetyLabellingConfig::min_segment_cells)
      .closed(0, 1000000)
      .unit("cells")
      .live(kStage)
      .doc("n_small: smaller segments are Unknown (000 Alg. 2 step 3: 6).");
  l.add("thin_ratio", &M::labelling, &SafetyLabellingConfig::thin_ratio)
      .closed(0, 1000)
      .live(kStage)
      .doc(
          "r_thin: segments with #interior < r_thin #boundary are Unknown (000 Alg. 2 step 4: "
          "0.1).");
  l.add("max_step_height", &M::labelling, &SafetyLabellingConfig::max_step_height)
      .openClosed(0, 10)
      .unit("m")
      .live(kStage)
      .doc("h_T: largest plane height difference the robot crosses (000 Alg. 2 step 17: 0.05).");
  l.add("step_height_margin", &M::labelling, &SafetyLabellingConfig::step_height_margin)
      .closedOpen(0, 10)
      .unit("m")
      .live(kStage)
      .doc(
          "taken off h_T wherever Alg. 2 asks whether a step between two measured surfaces is "
          "crossable (planes, measured surfaces, isolated ground; not the footprint bridge): "
          "stereo reads a step low, so a step "
          "measured within this margin of h_T is not crossed; must be below h_T (ours; 0 = 000).");
  l.add("min_passage_cells", &M::labelling, &SafetyLabellingConfig::min_passage_cells)
      .closed(1, 100000)
      .unit("cells")
      .live(kStage)
      .doc(
          "num_T, the robot's width: crossable border cells needed to reach a neighbouring "
          "segment (000 Alg. 2 step 21: 5).");
  l.add("max_gap_cells", &M::labelling, &SafetyLabellingConfig::max_gap_cells)
      .closed(0, 10)
      .unit("cells")
      .doc(
          "segments this many unobserved cells apart are neighbours in Alg. 2; h_T and num_T "
          "still decide reachability (ours; 0 = 000 Sec. VI).");
  l.add("measured_step_test", &M::labelling, &SafetyLabellingConfig::measured_step_test)
      .doc(
          "a border cell is also crossable when the measured surface heights of the two cells "
          "differ by less than h_T: a level floor's plane does not model the start of a ramp in "
          "its band (ours; false = 000 Alg. 2 steps 15-17).");
  l.add("small_obstacles", &M::labelling, &SafetyLabellingConfig::small_obstacles)
      .doc(
          "a segment Alg. 2 steps 3-4 call Unknown (small, thin, no plane) that stands more than "
          "h_T above the safe ground beside it is the top of an obstacle: Non-ground (ours; false "
          "= 000).");
  l.add("small_obstacle_min_rise", &M::labelling, &SafetyLabellingConfig::small_obstacle_min_rise)
      .closed(0, 10)
      .unit("m")
      .doc(
          "the smallest rise above every safe segment beside it that makes such a segment an "
          "obstacle's top; smaller bumps are within stereo's noise at range (ours).");
  l.add("floor_fragments", &M::labelling, &SafetyLabellingConfig::floor_fragments)
      .doc(
          "a segment Alg. 2 steps 3-4 call Unknown whose every border runs along safe ground (or "
          "other such fragments) with measured surface heights within floor_fragment_tolerance is "
          "that ground: floor noise a voxel high is not a hole ringed with drop-off edges (ours; "
          "false = 000).");
  l.add("floor_fragment_tolerance", &M::labelling, &SafetyLabellingConfig::floor_fragment_tolerance)
      .closed(0, 1)
      .unit("m")
      .doc(
          "floor_fragments: how close the measured surfaces of a fragment and of the ground "
          "around it must be at every contact; below h_T, as a small obstacle's top reads low "
          "in the same noise (ours).");
  l.add("robot_fragment_passage", &M::labelling, &SafetyLabellingConfig::robot_fragment_passage)
      .doc(
          "a robot's segment that Alg. 2 steps 3-4 would call small or thin (the floor around "
          "the robot seen a voxel above the base) counts num_T on the other side of a border "
          "with no failed contact; off: such a map, which the pose does not fit, stays "
          "unreachable (ours; false = 000).");
  l.add("footprint_bridge", &M::labelling, &SafetyLabellingConfig::footprint_bridge)
      .closed(0, 10)
      .unit("m")
      .doc(
          "the robot's footprint and ground this far beyond it with only unobserved cells between "
          "(the camera's blind zone) are neighbours in Alg. 2; h_T and num_T decide (ours; 0 = "
          "off).");
  l.add("bridge_tilt_deg", &M::labelling, &SafetyLabellingConfig::bridge_tilt_deg)
      .closed(0, 10)
      .unit("deg")
      .doc(
          "the chassis tilt odometry does not report, allowed for across the footprint bridge: "
          "its far cell is crossable within h_T + d tan(bridge_tilt_deg) of the footprint's "
          "level plane, d its distance from the robot (ours; 0 = h_T alone).");
  l.add("isolated_ground_unknown", &M::labelling, &SafetyLabellingConfig::isolated_ground_unknown)
      .doc(
          "ground that is not reached only because no observed border leads to it (no border to "
          "safe ground with a failed step, height within h_T + d tan(theta_max) of the nearest "
          "safe cell) is Unknown, not Non-ground; a failed step or an implausible height keeps "
          "Non-ground (ours; false = 000 Alg. 2 step 27).");
  l.add("drop_off_margin", &M::labelling, &SafetyLabellingConfig::drop_off_margin)
      .doc(
          "border cells of safe segments beside an observed surface lower by more than "
          "max(h_T, drop_off_min_drop) are Non-ground: stereo carries a drop's upper edge over "
          "the lower level (ours; false = 000).");
  l.add("drop_off_sink", &M::labelling, &SafetyLabellingConfig::drop_off_sink)
      .closed(0, 10)
      .unit("m")
      .doc(
          "with drop_off_margin: a border cell of a safe segment next to a cell never seen whose "
          "measured surface lies more than this below its segment's plane is a drop's edge whose "
          "lower side was not seen: Non-ground (ours; 0 = off, as 000).");
  l.add("obstacle_face_margin", &M::labelling, &SafetyLabellingConfig::obstacle_face_margin)
      .doc(
          "border cells of safe segments beside an observed column in no safe segment whose "
          "surface stands more than max(h_T, obstacle_face_min_rise) above them are Non-ground: "
          "an obstacle's face may stand inside the floor's last cell (ours; false = 000).");
  l.add("obstacle_face_min_rise", &M::labelling, &SafetyLabellingConfig::obstacle_face_min_rise)
      .closed(0, 10)
      .unit("m")
      .doc(
          "with obstacle_face_margin: the smallest rise of the neighbour's surface that makes "
          "a face (below h_T: h_T; at h_T the margin also rings stereo's 5-10 cm floor bumps).");
  l.add("obstacle_face_reach", &M::labelling, &SafetyLabellingConfig::obstacle_face_reach)
      .closed(0, 10)
      .unit("m")
      .doc(
          "with obstacle_face_margin: the face column makes the margin only when one of its "
          "surface points lies within this distance of the border it shares with the cell "
          "(ours; >= l_v: every face column).");
  l.add("obstacle_face_reach_sigmas", &M::labelling,
        &SafetyLabellingConfig::obstacle_face_reach_sigmas)
      .closed(0, 100)
      .doc(
          "with obstacle_face_reach below l_v: a point's reach is at least this many stereo "
          "range errors at its range, k disparity_sigma r^2 / (f b) (001 Sec. 4.1; ours; 0 = the "
          "fixed reach).");
  l.add("mark_drop_offs", &M::labelling, &SafetyLabellingConfig::mark_drop_offs)
      .live(kStage)
      .doc("annotate potential drop-off edges (000 Sec. VI).");
  l.add("drop_off_radius", &M::labelling, &SafetyLabellingConfig::drop_off_radius)
      .closed(0, 10)
      .unit("m")
      .live(kStage)
      .doc("how \"close\" lower cells must be to a drop-off edge (000 Sec. VI gives no value).");
  l.add("drop_off_min_drop", &M::labelling, &SafetyLabellingConfig::drop_off_min_drop)
      .closed(0, 10)
      .unit("m")
      .live(kStage)
      .doc("smallest drop that marks an edge (000 Sec. VI \"lower\"; h_T).");

  l.section("Frames (000 Sec. IV)");
  l.add("skip_stationary_frames", &M::skip_stationary_frames)
      .live(kStage)
      .doc("discard frames taken while the camera has not moved (000 Sec. IV).");
  l.add("stationary_translation", &M::stationary_translation)
      .closed(0, 100)
      .unit("m")
      .live(kStage)
      .doc(
          "camera motion below which a frame is stationary (ours; 0.02 skipped every third "
          "frame of a 0.3 m/s drive at 15 Hz).");
  l.add("stationary_rotation_deg", &M::stationary_rotation_deg)
      .closed(0, 180)
      .unit("deg")
      .live(kStage)
      .doc("camera rotation below which a frame is stationary (ours).");
  l.add("stationary_warmup_frames", &M::stationary_warmup_frames)
      .closed(0, 100000)
      .live(kStage)
      .doc(
          "stationary frames are integrated all the same until the grid holds this many frames "
          "since it was (re)started, so that a chair switched on at rest sees its obstacles "
          "(a voxel needs occ_t / incr_H = 10 hits) before it moves (ours; 0 = 000 Sec. IV, "
          "every stationary frame skipped). 10 = occ_t / incr_H.");
  l.add("scroll_with_robot", &M::scroll_with_robot)
      .doc("keep the grid centred on the robot (000 Sec. IV allows either).");
  l.add("grid_look_ahead", &M::grid_look_ahead)
      .atLeast(0)
      .rangeText("[0, min(size_x, size_y) / 2 - planning_radius]")
      .unit("m")
      .doc(
          "centre the window this far ahead of the robot along the camera's heading: with 10 m "
          "it reaches 6 m ahead and R_max behind (ours; 0 = centred on the robot, 000).");
  l.add("max_cell_age", &M::max_cell_age)
      .closed(0, 86400)
      .unit("s")
      .live(kStage)
      .doc(
          "Level / Inclined cells whose column got no point for longer fall back to Unknown, 0 = "
          "off; Non-ground never changes (ours, observation_age.h; README, "
          "[Reliability](#reliability)).");
  l.add("obstacle_memory", &M::obstacle_memory)
      .doc(
          "a cell that held an obstacle (its measured top more than h_T above the safe ground "
          "around it) stays Non-ground until free space is observed there (its occupied voxels "
          "emptied by passing rays) (ours; false = 000, which recomputes the map from the "
          "grid).");
  l.add("obstacle_memory_clear_margin", &M::obstacle_memory_clear_margin)
      .closed(1, 65535)
      .rangeText("[1, occ_threshold - lop_min]")
      .doc(
          "a remembered obstacle cell is forgotten once every voxel of its band has a log-odds at "
          "or below occ_threshold minus this: 1 = as soon as none is occupied; occ_threshold = "
          "only when passing rays took the band back to the prior, which also keeps a removed "
          "obstacle for many frames (ours).");
  l.add("obstacle_memory_max_range", &M::obstacle_memory_max_range)
      .closed(0, 1000)
      .unit("m")
      .doc(
          "the memory takes a column only while it lies within this distance of the robot: "
          "stereo's depth error grows with the range squared (001 Sec. 4.1), and the floor's "
          "outliers at range are no obstacle to keep (ours; 0 = any range).");
  l.add("relevel", &M::relevel, &FrameLevellingConfig::enabled)
      .doc(
          "correct each frame's pitch, roll and height on the robot's level ground in the previous "
          "map: chassis bobbing that odometry does not report (ours, frame_levelling.h; false = "
          "000).");
  l.add("relevel_max_deg", &M::relevel, &FrameLevellingConfig::max_correction_deg)
      .openClosed(0, 20)
      .unit("deg")
      .doc("larger corrections are refused: not chassis bobbing (ours).");
  l.add("relevel_near_radius", &M::relevel, &FrameLevellingConfig::near_radius)
      .closed(0, 10)
      .unit("m")
      .doc(
          "the reference ground: 0 = the previous map's robot-segment cells on the base's level "
          "plane; > 0 = the base's level plane over every cell within this distance of the base, "
          "the ground the chair stands on (the map's cells were built with the same tilt) (ours).");
  l.add("relevel_filter_frames", &M::relevel, &FrameLevellingConfig::filter_frames)
      .closed(0, 1000)
      .doc(
          "0 = each frame corrected by its own estimate; N = by the median of the last N "
          "accepted estimates in the camera heading's frame: the constant part of an unreported "
          "tilt (seat load, tyres, a mount calibrated a little off), robust to a ramp or drop "
          "ahead (ours).");
  l.add("relevel_estimate_offset", &M::relevel, &FrameLevellingConfig::estimate_offset)
      .doc(
          "estimate the camera's vertical offset with its tilt (true) or the tilt alone with "
          "the camera's height kept (false): the ground seen spans 1-2 m along the heading, "
          "over which a pitch and an offset shift the heights almost alike (ours).");
  l.add("overhang_roof", &M::overhang_roof, &OverhangRoofConfig::enabled)
      .doc(
          "a safe cell whose floor the camera sees under the top of an overhang column (a top "
          "with rays observed passing below it) at most overhang_roof_max_span before it is "
          "Non-ground: the table top or shelf board stereo saw only at its front edge (ours, "
          "overhang_roof.h; false = 000).");
  l.add("overhang_roof_min_clearance", &M::overhang_roof, &OverhangRoofConfig::min_clearance)
      .closed(0, 5)
      .unit("m")
      .doc("overhang_roof: a roof's top stands at least this far above the robot's base (ours).");
  l.add("overhang_roof_max_span", &M::overhang_roof, &OverhangRoofConfig::max_span)
      .openClosed(0, 10)
      .unit("m")
      .doc(
          "overhang_roof: the floor seen under an overhang's front edge is Non-ground this far "
          "behind it: the depth of a top whose far side is not seen (ours).");
  l.add("overhang_roof_min_free_voxels", &M::overhang_roof, &OverhangRoofConfig::min_free_voxels)
      .closed(1, 100)
      .doc(
          "overhang_roof: voxels below an overhang column's top that rays must have observed "
          "free (ours).");
  l.add("overhang_roof_memory", &M::overhang_roof, &OverhangRoofConfig::remember)
      .doc(
          "overhang_roof with obstacle_memory: a cell marked as floor under a roof stays "
          "Non-ground while the top voxel of the roof column that marked it stays occupied, "
          "whatever the later lines of sight (ours; false = marked from the last frame's view "
          "only).");
  l.add("unseen_overhang_min_height", &M::unseen_overhang_min_height)
      .closed(0, 5)
      .unit("m")
      .doc(
          "a Level / Inclined cell outside the footprint whose column, from this height above "
          "its ground up to the robot's top, holds a voxel not seen (log-odds between "
          "-unseen_overhang_free_lop and occ_threshold) below one seen (the edge-on top of a "
          "table stereo did not match, rays passing under and over it) is Unknown (ours; 0 = "
          "off).");
  l.add("unseen_overhang_non_ground", &M::unseen_overhang_non_ground)
      .doc("unseen_overhang_min_height's cells are Non-ground instead of Unknown (ours).");
  l.add("unseen_overhang_min_width", &M::unseen_overhang_min_width)
      .closed(1, 9)
      .doc(
          "unseen_overhang_min_height: only hidden cells that belong to a square of this side "
          "[cells] hidden throughout count (an opening): a top hides a layer across its extent, "
          "the voxels rays happen to miss lie in scattered cells and thin stripes (ours; 1 = "
          "every hidden cell).");
  l.add("unseen_floor_band", &M::unseen_floor_band)
      .closed(0, 10)
      .unit("voxels")
      .doc(
          "a Level / Inclined cell outside the footprint none of whose voxels 1 .. this many "
          "above its ground was ever seen free (log-odds at or below -unseen_overhang_free_lop) "
          "is Unknown: floor that stereo's noise pushed behind an obstacle's face, above which "
          "no ray passed (ours; 0 = off; off while decr = 0).");
  l.add("unseen_floor_min_range", &M::unseen_floor_min_range)
      .closed(0, 100)
      .unit("m")
      .doc(
          "unseen_floor_band applies from this horizontal distance of the robot on: near the "
          "chair stereo's depth error is a small fraction of a cell (ours).");
  l.add("unseen_overhang_free_lop", &M::unseen_overhang_free_lop)
      .closed(1, 32768)
      .rangeText("[1, -lop_min]")
      .doc(
          "unseen_overhang_min_height: a voxel is seen free once passing rays took its log-odds "
          "to -this or below; between that and occ_threshold it was not seen (a 4 cm top in a "
          "10 cm voxel lets a few rays graze it) (ours).");
  l.setValidator(mapperParameterError);
  return l;
}

// The filter's messages name its struct's fields; the parameters carry the landmark_ prefix.
std::string landmarkParameterError(const L& c) {
  std::string err = c.filter.validate();
  const std::string far = "max_landmark_distance";
  if (err.compare(0, far.size(), far) == 0) {
    err = "landmark_max_distance" + err.substr(far.size());
  } else if (!err.empty()) {
    err = "landmark_" + err;
  }
  return err;
}

ParamFieldList<L> makeLandmarkFields() {
  ParamFieldList<L> l;
  l.section(
      "Landmark filter of the point stream (001 Sec. 4.2; `core/landmark_filter.h`), `input: "
      "disparity` only. A point reaches the voxel grid only when a permanent landmark confirms "
      "it; the filter sees the frames the grid integrates (stationary frames are skipped by "
      "both), so the first `landmark_min_matches` moving frames give no map");
  l.add("use_landmark_filter", &L::enabled)
      .doc("turn the filter on (001 Sec. 4.2; off: 000's pipeline as published).");
  l.add("landmark_sigma_row", &L::filter, &LandmarkFilterConfig::error_model,
        &StereoErrorModelConfig::sigma_row)
      .above(0)
      .unit("px")
      .doc("sigma_r, row noise of Eq. (1) (001 gives no value).");
  l.add("landmark_sigma_col", &L::filter, &LandmarkFilterConfig::error_model,
        &StereoErrorModelConfig::sigma_col)
      .above(0)
      .unit("px")
      .doc("sigma_c, column noise of Eq. (1).");
  l.add("landmark_sigma_disparity", &L::filter, &LandmarkFilterConfig::error_model,
        &StereoErrorModelConfig::sigma_disparity)
      .above(0)
      .unit("px")
      .doc("sigma_d, disparity noise of Eq. (1).");
  l.add("landmark_gate_chi2", &L::filter, &LandmarkFilterConfig::gate_chi2)
      .above(0)
      .doc(
          "gate on the squared Mahalanobis distance (001 Sec. 4.2: chi-square, 3 degrees of "
          "freedom, 99 %).");
  l.add("landmark_use_mahalanobis", &L::filter, &LandmarkFilterConfig::use_mahalanobis)
      .doc("false = the Euclidean baseline of 001 Fig. 4, gated at `~landmark_euclidean_gate`.");
  l.add("landmark_euclidean_gate", &L::filter, &LandmarkFilterConfig::euclidean_gate)
      .above(0)
      .unit("m")
      .doc("the Euclidean gate when landmark_use_mahalanobis is false (001 Fig. 4).");
  l.add("landmark_min_matches", &L::filter, &LandmarkFilterConfig::min_matches)
      .closed(1, 65535)
      .doc("matches that make a temporary landmark permanent (not in 001).");
  l.add("landmark_time_window", &L::filter, &LandmarkFilterConfig::time_window)
      .above(0)
      .unit("s")
      .doc(
          "a temporary landmark without min_matches matches within this time is removed (not "
          "in 001).");
  l.add("landmark_stale_time", &L::filter, &LandmarkFilterConfig::stale_time)
      .above(0)
      .rangeText("> 0 or .inf")
      .unit("s")
      .doc(
          "a permanent landmark in view that stops matching for this long is removed (moved "
          "objects; 001 keeps them).");
  l.add("landmark_max_landmarks", &L::filter, &LandmarkFilterConfig::max_landmarks)
      .closed(1, 1 << 30)
      .rangeText("[1, 2^30]")
      .doc("capacity; new landmarks are refused beyond it (ours).");
  l.add("landmark_max_search_radius_px", &L::filter, &LandmarkFilterConfig::max_search_radius_px)
      .closed(1, 256)
      .unit("px")
      .doc("cap on a landmark's candidate window (ours).");
  l.add("landmark_max_distance", &L::filter, &LandmarkFilterConfig::max_landmark_distance)
      .above(0)
      .rangeText(">= max_range")
      .unit("m")
      .doc("landmarks farther from the camera are dropped: a local map (ours).");
  l.setValidator(landmarkParameterError);
  return l;
}

ParamFieldList<RowGapFillConfig> makeRowGapFillFields() {
  using G = RowGapFillConfig;
  ParamFieldList<G> l;
  l.section("Reprojection");
  l.add("row_gap_fill", &G::enabled)
      .doc(
          "fill the gap between two valid disparities of an image row that agree, on the "
          "safety map's copy of the disparity (low-texture floors; ours, false = 000).");
  l.add("row_gap_fill_max_width", &G::max_width)
      .openClosed(0, 10)
      .unit("m")
      .doc("widest gap filled, at the gap's depth (ours).");
  l.add("row_gap_fill_max_step", &G::max_step)
      .openClosed(0, 4)
      .unit("px")
      .doc(
          "largest disparity difference across a filled gap: a 5 cm step at 8 m is > 0.3 px "
          "with the 0.12 m head (ours).");
  l.setValidator([](const G& c) { return c.validate(); });
  return l;
}

ParamFieldList<StereoFrameProcessorConfig> makeProcessorFields() {
  using P = StereoFrameProcessorConfig;
  ParamFieldList<P> l;
  l.include(safetyMapperFields(), &P::mapper);
  l.section("Reprojection");
  l.add("disparity_step", &P::disparity_step)
      .closed(1, 16)
      .doc("use every n-th pixel in rows and columns.");
  l.include(rowGapFillFields(), &P::row_gap_fill);
  l.add("coarse_free_space", &P::coarse_free_space)
      .doc(
          "the coarse fill's readings (coarse_fill_levels) carve free space like any reading; "
          "false: occupancy evidence alone, their rays carve nothing (ours; offline only: the "
          "disparity nodelet publishes the merged readings).");
  l.include(landmarkStreamFields(), &P::landmark_filter);
  l.include(disparityPipelineFields(), &P::disparity);
  l.setValidator([](const P& c) { return c.validate(); });
  return l;
}

}  // namespace

const ParamFieldList<RowGapFillConfig>& rowGapFillFields() {
  static const ParamFieldList<RowGapFillConfig> l = makeRowGapFillFields();
  return l;
}

const ParamFieldList<SafetyMapperConfig>& safetyMapperFields() {
  static const ParamFieldList<SafetyMapperConfig> list = makeMapperFields();
  return list;
}

const ParamFieldList<LandmarkStreamConfig>& landmarkStreamFields() {
  static const ParamFieldList<LandmarkStreamConfig> list = makeLandmarkFields();
  return list;
}

const ParamFieldList<StereoFrameProcessorConfig>& stereoFrameProcessorFields() {
  static const ParamFieldList<StereoFrameProcessorConfig> list = makeProcessorFields();
  return list;
}

}  // namespace stereo_safety_map
