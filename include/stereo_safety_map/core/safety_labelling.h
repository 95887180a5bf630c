// Labelling of ground segments for connectivity and safety and construction of the local safety
// map with potential drop-off edges (paper 000, Sec. VI, Alg. 2).
//
// ROS-free. Input: the height map, the segments of Alg. 1 and one plane per segment (Sec. V-B).
#pragma once

#include "stereo_safety_map/core/ground_segmentation.h"
#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/safety_map.h"

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct SafetyLabellingConfig {
  double max_slope_deg = 10.0;  ///< theta_max: steeper planes are Non-ground (000, Alg. 2 step 2)
  /// [deg], [0, theta_max - theta_T]: taken off theta_max where Alg. 2 step 2 judges a plane's
  /// slope, so that a plane measured within the margin of theta_max is Non-ground (ours; 0 =
  /// 000), the slope twin of step_height_margin. On the open-world dev split 1 or 2 deg changed
  /// nothing: the 11-12 deg ramps that read safe there are cells joined to the floor's band,
  /// not planes measured just under theta_max (docs/evaluation.md, twenty-second session).
  /// theta_max itself (the ground truth's and the paper's) stays the Inclined cost's upper end.
  double slope_margin_deg = 0.0;
  /// theta_max less slope_margin_deg: the steepest measured plane Alg. 2 step 2 lets be safe.
  double traversableSlope() const { return max_slope_deg - slope_margin_deg; }
  int min_segment_cells = 6;      ///< n_small: smaller segments are Unknown (Alg. 2 step 3)
  double thin_ratio = 0.1;        ///< r_thin: #interior < r_thin #boundary is thin (Alg. 2 step 4)
  double max_step_height = 0.05;  ///< h_T [m]: largest plane height difference crossable (step 17)
  /// [m], [0, h_T): the height measurement's uncertainty, taken off h_T wherever Alg. 2 asks
  /// whether a step between two measured surfaces is crossable (steps 15-17 on the planes,
  /// measured_step_test, the plausibility test of isolated_ground_unknown; not the footprint
  /// bridge, whose near side is the base's assumed height), so that a step measured
  /// within the margin of h_T is not crossed (ours; 0 = 000). Stereo reads a step low: the
  /// lower side's points spread into the voxel above, whose points stand in front of the
  /// surface, and a drop of 5.6-6.2 cm (h_T + 0.6-1.2 cm) read 2.9-4.5 cm on the dev split
  /// (perfect pose, docs/evaluation.md "Steps just above h_T"). h_T itself (the ground truth's
  /// and the paper's) is what the chair may cross; the margin is what the map cannot tell
  /// apart from it. The obstacle and drop thresholds (small_obstacle_min_rise,
  /// drop_off_min_drop) keep h_T.
  double step_height_margin = 0.01;
  /// h_T less step_height_margin: the largest measured step Alg. 2 crosses.
  double crossableStep() const { return max_step_height - step_height_margin; }
  int min_passage_cells = 5;     ///< num_T: robot width in cells (Alg. 2 step 21)
  double level_slope_deg = 3.0;  ///< theta_T: steeper safe planes are Inclined (Alg. 2 step 28)
  /// Neighbouring segments across unobserved cells (ours; 0 = 000 Sec. VI, where two segments
  /// are neighbours only when boundary cells touch). Stereo leaves gaps in low-texture ground,
  /// so the ground of one surface often falls apart into segments a cell or two apart. A
  /// boundary cell of S and a cell of R at most max_gap_cells + 1 cells apart (Chebyshev) with
  /// only columns without any height on the straight line between them count as neighbouring
  /// boundary cells of Alg. 2 steps 11-19; the h_T and num_T tests are unchanged, so a drop
  /// across a gap still separates. The gap cells themselves stay Unknown.
  int max_gap_cells = 2;
  /// Step test on measured heights as well (ours; false = 000 Alg. 2 steps 15-17 alone). The
  /// paper compares the two segments' planes at a border cell's centre. A segment is a band of
  /// one indexed height, so where a level floor runs into a ramp the floor's segment also holds
  /// the ramp's first few decimetres, which its level plane does not model: at the border the
  /// planes then differ by up to a voxel although the surface is continuous, and ramps become
  /// unreachable. With this on, a border cell is also crossable when the local surface heights
  /// of the two segments there differ by less than h_T, the ground truth's own test of a
  /// drivable transition. The local surface height of a segment at a cell is the mean measured
  /// height (HeightMap::surfaceHeightAtIndex, the mean height of the column's top-voxel points)
  /// of the segment's cells within 2 cells: one column alone is too noisy, and along a curb
  /// the columns of the curb's face, halfway down, would let a few border cells through.
  bool measured_step_test = true;
  /// Small obstacles are obstacles (ours; false = 000 Alg. 2 steps 3-4 alone). Alg. 2 calls a
  /// segment smaller than n_small, or thin, Unknown before reachability is asked: right for a
  /// small patch of ground, wrong for the top of a pole, a bin, a bollard or a chair seat, which
  /// make exactly such segments; a planner that drives through Unknown would drive into them.
  /// With this on, a segment left Unknown by steps 3-4 (or for want of a plane) whose measured
  /// surface (local surface heights, see measured_step_test) rises above every adjacent safe
  /// segment's by more than max(h_T, small_obstacle_min_rise) at their borders (gaps of
  /// max_gap_cells included) is Non-ground. Every, not any: a fragment at the foot of a ramp
  /// continues the ramp beside it.
  bool small_obstacles = true;
  /// [m], [0, 10]: the smallest rise that makes a small segment an obstacle's top. 0.08: the
  /// top voxel's points of a floor patch in stereo's noise at 3-4 m stand 4-7 cm above the floor
  /// around it (the closed-loop gate test's corridor and 5 deg ramp, where h_T alone stopped
  /// the chair on level floor); a 10 cm obstacle's top stands 8-10 cm above it. Bumps of 5-8 cm
  /// are within the noise and stay Unknown.
  double small_obstacle_min_rise = 0.08;
  /// Fragments of the floor's noise are the floor (ours; false = 000 Alg. 2 steps 3-4 alone).
  /// Alg. 1 cuts a segment wherever the indexed height w changes, so a column whose top voxel is
  /// one voxel higher than its neighbours' (the floor's points spread over two voxels by depth
  /// noise or by a chassis tilt odometry does not report: 1 deg moves ground 3 m away by 5 cm)
  /// becomes a segment of a cell or two, which step 3 calls Unknown. Amid a level floor those
  /// holes read as unsafe, ring themselves with potential drop-off edges and stop the gate. With
  /// this on, a segment steps 3-4 left Unknown (small, thin or without a plane), not an
  /// obstacle's top (small_obstacles), is safe like the ground around it when every segment it
  /// borders (touching or across max_gap_cells) is safe or another such fragment, at least one
  /// is safe, and at every contact of the border the measured surface heights (see
  /// measured_step_test) of the two sides differ by less than floor_fragment_tolerance (below
  /// h_T, the ground truth's own test of a drivable transition). It takes the label and plane
  /// of the safe segment it shares the most contacts with (SegmentInfo::merged_into). A
  /// fragment next to anything not safe (a drop's lower side, an unreached segment, the
  /// footprint's bridge) or standing or sunk by the tolerance or more anywhere along its border
  /// stays Unknown (or Non-ground); beside a non-traversable column (no segment) it is floor
  /// like any floor cell there, and the drop-off margin applies to it alike. Needs the
  /// measured heights: inert when measured_step_test and small_obstacles are both off.
  bool floor_fragments = true;
  /// [m], [0, 1]: how close the measured surfaces of a fragment and of the ground around it
  /// must be at every contact of their border. Below h_T: stereo's noise and the tilt that moves
  /// the floor a voxel up move a small obstacle's top down towards it too (a 9.5 cm bag read
  /// within h_T of the floor beside it on the dev split), and a fragment left Unknown is unsafe.
  double floor_fragment_tolerance = 0.03;
  /// The robot's own segment a fragment (ours, off; false = 000 Alg. 2 step 21). The seed rule
  /// (GroundSegmentationConfig::seed_radius) takes the cell at the base's indexed height, and
  /// where the floor around the robot was seen a voxel higher (from afar, under a chassis tilt
  /// odometry does not report) only a cell or two are left there: a robot's segment too short
  /// for num_T at any border, so the whole map is Non-ground. With this on, num_T is counted on
  /// the other side of a border along which none of the fragment's contacts failed (the robot
  /// stands there; the short border is no narrow passage; h_T still separates a step or drop).
  /// Off by default: those are the frames whose map disagrees with the pose by a voxel, and on
  /// the dev split the maps it gives back (FP 19.89 -> 17.80 %) read a 6 cm step and an 8.5 cm
  /// box as floor (FN 2.85 -> 3.43 %): calling the area unsafe is the safe answer to a map the
  /// pose does not fit.
  bool robot_fragment_passage = false;
  /// Across the camera's blind zone (ours; 0 = off, 000 Sec. VI's touching neighbours). A camera
  /// on the chair sees the ground only from 0.7-1.9 m ahead of the base (its height and pitch);
  /// until the robot has driven over the ground it saw, the cells between its footprint
  /// (GroundSegments::footprint) and the first observed ground have no height. With this on,
  /// the footprint's boundary cells and the boundary cells of other segments at most
  /// footprint_bridge [m] apart, with only unobserved cells on the straight line between them,
  /// are neighbouring boundary cells of Alg. 2; the h_T test at the far cell and num_T decide as
  /// for any border, and the unobserved cells stay Unknown. So an unobserved near field does not
  /// make the whole map unreachable, and a drop or step there still separates. [0, 10] m.
  double footprint_bridge = 1.5;
  /// [deg], [0, 10]: the chassis tilt that odometry does not report, allowed for across the
  /// footprint bridge (ours; 0 = h_T alone). The footprint's plane is the base's, level at the
  /// base's height; a chassis pitched by a degree that the tf does not know (seat load, tyres,
  /// a mount calibrated a little off) moves the ground seen d m away by d tan(1 deg), 2.6 cm at
  /// 1.5 m, and the top voxel's points of noisy ground stand above its mean. So the far cell of a
  /// bridge is crossable when its plane is within h_T + d tan(bridge_tilt_deg) of the footprint's
  /// (d its distance from the robot's cell). A 10 cm step at 1.5 m still separates.
  double bridge_tilt_deg = 1.0;
  /// Ground cut off only by what was not seen is Unknown (ours; false = 000 Alg. 2 step 27,
  /// where every segment not reached is Non-ground). Stereo sees the ground in patches: a
  /// low-texture floor between the robot and a ramp 3 m away leaves the ramp with no border to
  /// any safe segment, and Alg. 2 then calls a drivable ramp an obstacle. With this on, the
  /// segments not reached are grouped by their crossable borders; a group with no border to a
  /// safe segment that has a failed contact (touching, across max_gap_cells or the footprint
  /// bridge; a border whose every contact is crossable but too short for num_T, e.g. where the
  /// footprint bridge's reach only grazes ground seen beyond the blind zone, is no measured
  /// discontinuity) and no cell within
  /// max_gap_cells + 2 cells of safe ground is Unknown when a boundary cell of it could be
  /// reached from its nearest safe cell along a drivable slope over cells of which nothing was
  /// seen: its plane's height there differs from the safe cell's by at most h_T + d
  /// tan(theta_max) (d the distance between the two) and the straight line between them crosses
  /// no observed column. A group that borders safe ground across a failed step or a face's
  /// columns stays Non-ground (a measured discontinuity), and so does one standing higher or
  /// lower than any drivable slope allows (an obstacle's top seen beyond unobserved floor, a
  /// lower level) or seen only across observed columns (behind a wall).
  /// Unknown is never free: the cost table makes it -1 and the gate stops for it.
  bool isolated_ground_unknown = true;

  /// Potential drop-off edges (000, Sec. VI). A boundary cell of a Level / Inclined segment is one
  /// when it has an Unknown 8-neighbour and, within drop_off_radius [m] of its centre, a cell
  /// whose column (indexed) height l_v w is lower than the cell's own plane height by more than
  /// drop_off_min_drop [m]. The paper only says "close"; the radius is set from the occlusion
  /// shadow behind a drop: seen from a camera H = 1.1 m high at distance d, a drop of h hides
  /// d h / H of the lower level (0.36 m for h = 0.2 m at d = 2 m, 0.55 m at 3 m).
  bool mark_drop_offs = true;
  /// A one-cell safety margin along observed drop-offs (ours; false = 000). Stereo's depth
  /// noise carries points of a drop-off's upper edge a few centimetres beyond it, so the upper
  /// surface's last column often lies already over the lower level (000 Sec. VII-A: obstacles
  /// "bleed"; at a drop-off the safe side bleeds). With this on, a border cell of a Level /
  /// Inclined segment whose 8-neighbour holds an observed surface lower than its own (local
  /// surface heights, see measured_step_test), and lower than the segment's plane carried on
  /// to that neighbour, by more than max(h_T, drop_off_min_drop) is Non-ground (the plane test
  /// keeps a ramp's foot, where the ramp's averaged local surface stands above the floor, from
  /// reading as a drop). Drop-offs whose lower side is hidden (next to Unknown) keep 000's
  /// potential drop-off edge annotation.
  bool drop_off_margin = true;
  /// [m], [0, 10]: a drop's edge whose lower side was never seen (ours; 0 = off, as 000). The
  /// lower level beyond a curb seen at a grazing angle or outside the camera's field of view has
  /// no column of its own, but the columns at its edge hold points of it: their top voxel (the
  /// upper surface's band) takes the lower surface's upper noise tail and the edge's, and their
  /// measured surface sinks below the upper surface's plane (dev seed 44, a 6.2 cm curb seen
  /// from the side: 2.1-3.0 cm below it, the sidewalk's boundary cells elsewhere within 1 cm).
  /// With this above 0 and drop_off_margin on, a border cell of a Level / Inclined segment next
  /// to an examined cell without any height whose measured surface lies more than this below
  /// its segment's plane is Non-ground, as the drop_off_margin cells are. Boundary cells of a
  /// safe segment next to unobserved cells, pooled over dev seeds 44, 49, 5, 37: 1.1 % of those
  /// on safe ground sink by more than 2.5 cm, 64 % of those over lower ground.
  double drop_off_sink = 0.025;
  double drop_off_radius = 0.5;
  double drop_off_min_drop = 0.05;  ///< defaults to h_T: a smaller drop is crossable
  /// A one-cell margin along observed obstacle faces (ours; false = 000, issue 15 "cells that
  /// hold an obstacle's face are never Level"). A cell is 10 cm wide: the face of a pole, a wall,
  /// a curb up or a table's edge often stands inside the floor's last cell while the points of
  /// the face fall in the next column, and that cell reads Level. With this on, a border cell of
  /// a Level / Inclined segment whose 8-neighbour is an observed column in no safe segment (a
  /// non-traversable column, or a segment labelled Non-ground or Unknown) whose measured
  /// surface stands more than max(h_T, obstacle_face_min_rise) above the cell's own local
  /// surface is Non-ground, as the drop_off_margin cells are. With the mapper's obstacle_memory,
  /// such a cell stays Non-ground while the top voxel of the face's column stays occupied
  /// (SafetyLabelling::faceMarks, SafetyMapper's face memory).
  bool obstacle_face_margin = true;
  /// [m], [0, 10]: the rise that makes a face (below h_T: h_T). 0.1 m, the smallest
  /// obstacle: at h_T the margin also rings stereo's 5-10 cm bumps on the floor (dev split,
  /// default degradations, the labelling alone: FP 21.71 -> 24.70 % at h_T, 21.88 % at 0.1 m;
  /// with the face memory 21.91 %; of the false positives
  /// it adds on the end-to-end test's scene, 71 % at h_T and 22 % at 0.1 m lie more than a cell
  /// from any obstacle or edge).
  double obstacle_face_min_rise = 0.1;
  /// [m], [0, 10]: the face's column makes the margin only when one of its surface points (the
  /// point lists of its top voxel and the voxel below) lies within this distance of the border
  /// it shares with the cell (for a diagonal neighbour: of the shared corner, along both axes);
  /// a face whose points all stand deeper in its own column does not reach into the cell (ours;
  /// >= l_v: every face column, the margin as first built). Needs the voxel grid
  /// (setVoxelGrid(), which SafetyMapper does); without one every face column counts. Default
  /// 0.03 m with obstacle_face_reach_sigmas 2 (twenty-ninth session, README "Real data"): on the
  /// real pairs' single-frame maps the margin rang every obstacle, FP 31-38 %; with the reach
  /// 25-28 %, FN with one cell of tolerance unchanged; on the open-world dev split FN 1.16 ->
  /// 1.18 %, the same obstacles missed, the same forgotten cells.
  double obstacle_face_reach = 0.03;
  /// [sigmas], [0, 100]: with obstacle_face_reach below l_v, a point's reach grows with stereo's
  /// range error: max(obstacle_face_reach, k sigma_d r^2 / (f b)) at the point's range r (001
  /// Sec. 4.1; sigma_d = disparity_sigma, f b from the grid's setStereoGeometry(); unknown f b:
  /// the fixed reach alone). A face seen from afar scatters its points deeper into its column
  /// (ours; 0 = the fixed reach). Default 2.
  double obstacle_face_reach_sigmas = 2.0;

  /// Empty when valid, otherwise a message naming the offending parameter and its range.
  std::string validate() const;
};

class SafetyLabelling {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit SafetyLabelling(const SafetyLabellingConfig& config = SafetyLabellingConfig());

  const SafetyLabellingConfig& config() const { return config_; }

  /// Alg. 2 and the safety map of Sec. VI. planes[k] is segment k's plane (missing entries count
  /// as invalid planes). Segment labels: invalid plane -> Unknown; slope > theta_max ->
  /// Non-ground; small or thin -> Unknown; the robot's segment -> safe (when its plane is valid);
  /// segments reached from a safe one -> safe; the rest -> Non-ground; safe -> Level / Inclined.
  /// Cells: their segment's label; non-traversable -> Non-ground; beyond R_max -> Unexamined;
  /// the rest -> Unknown. `map`'s buffers are reused.
  /// Returns false when the inputs disagree in size (height map vs segments) or voxel_size is not
  /// positive; `map` then covers the height map's window with every cell Unknown and no segments.
  bool label(const HeightMap& height_map, const GroundSegments& segments,
             const std::vector<GroundPlane>& planes, double voxel_size, SafetyMap* map);

  /// The last label() call's obstacle_face_margin cells, each with the neighbour column whose
  /// face made it (cell indices of the height map's window).
  struct FaceMark {
    int cell;
    int face_cell;
  };
  const std::vector<FaceMark>& faceMarks() const { return face_marks_; }

  /// The grid whose point lists obstacle_face_reach reads (nullptr: none; not owned, must
  /// outlive the label() calls and be the one the height map was built from).
  void setVoxelGrid(const VoxelGrid* grid) { grid_ = grid; }

 private:
  struct Contact {  // a boundary cell of segment s next to segment r
    int s;
    int r;
    int ok;      // 1 when the planes of s and r differ by less than h_T at the cell's centre
    float rise;  // s's local surface height minus r's there [m] (NaN when not measured)
    int cell;    // the boundary cell of s
    int close;   // 1 when a cell of r beside it has a measured surface within
                 // floor_fragment_tolerance of its own
  };
  struct Edge {  // all contacts of s with r, s's side only
    int r;
    int ok;
    int failed;  // contacts that are not crossable
    float rise;  // the largest rise of s over r along the border (NaN when none measured)
    int far;     // contacts not close (floor_fragments)
  };
  const Edge* edgeOf(int s, int r) const;  // s's side of the s-r border, nullptr when none
  int okCount(int s, int r) const;         // s's side of the s-r border, 0 when not neighbours
  int farCount(int s, int r) const;        // s's side: contacts not within the fragment tolerance
  bool borderFailed(int s, int r) const;   // a contact of the s-r border (either side) failed
  // isolated_ground_unknown, after Alg. 2 steps 5-26: turns the groups of unreached segments
  // without a border to safe ground that a drivable slope could reach into Unknown.
  void labelIsolatedGround(const HeightMap& hm, const SafetyMap& m, const GroundSegments& segs);
  // Mean measured surface height of the cells of c's segment within kLocalSurfaceRadius cells
  // of c (NaN when none has points); computed once per cell and label() call.
  float localSurfaceHeight(const HeightMap& hm, const GroundSegments& segs, int c);
  static constexpr int kLocalSurfaceRadius = 2;

  // obstacle_face_reach: whether a point of the face column cn's surface voxels lies within
  // reach of the border (or corner) it shares with cell c.
  bool faceReaches(const HeightMap& hm, int c, int cn, double voxel_size) const;

  SafetyLabellingConfig config_;
  const VoxelGrid* grid_ = nullptr;     // setVoxelGrid()
  std::vector<std::uint8_t> boundary_;  // per cell
  std::vector<float> local_z_;          // per cell, see localSurfaceHeight()
  std::vector<int> margin_;             // cells of the drop-off and obstacle face margins
  std::vector<FaceMark> face_marks_;    // the obstacle face margin's, see faceMarks()
  std::vector<Contact> contacts_;
  std::vector<Edge> edges_;  // sorted by (s, r), s's range is edge_begin_[s..s+1)
  std::vector<int> edge_begin_;
  std::vector<std::uint8_t> seg_state_;  // per segment, internal labels of Alg. 2
  std::vector<std::uint8_t> small_;      // per segment: Unknown by steps 3-4 or for no plane
  std::vector<int> host_;                // per segment: floor_fragments' host, -1 when none
  std::vector<int> bridge_from_;         // footprint boundary cells (footprint_bridge)
  std::vector<int> bridge_to_;           // boundary cells of other segments near the footprint
  std::vector<std::uint8_t> neighbours_examined_;
  std::vector<int> to_examine_;  // L_S of Alg. 2
  // isolated_ground_unknown: groups of segments not reached, the nearest safe cell of each cell
  // and its distance [cells] (chamfer transform).
  std::vector<int> group_;
  std::vector<std::uint8_t> group_blocked_;
  std::vector<int> group_stack_;
  std::vector<int> nearest_safe_;
  std::vector<float> safe_distance_;
};

}  // namespace stereo_safety_map
