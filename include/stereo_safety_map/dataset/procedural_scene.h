// Procedural scenes for the open-world evaluation: from a seed, a local area (about 10 x 10 m) on a
// base floor at z = 0 with 2-5 hazards a wheelchair meets (curbs and steps on both sides of h_T,
// curb cuts with flares, ramps near theta_T and theta_max, stairs down, drop-offs, poles and
// bollards, tables and shelves, thin legs, low obstacles, walls and doorways), floors from
// polished to paving, indoor and outdoor looks, a varied stereo head, and a wheelchair trajectory
// (pauses, turns in place, reversing, passes beside obstacles) that is checked never to drive
// into anything or off the start level. The scene is emitted as scene-file YAML
// (scenes/README.md) and parsed back with loadSceneFromString, so a generated scene can be written
// out, inspected, rendered with make_dataset and replayed like the hand-made ones. Thresholds
// are the labeller's (000 Alg. 2: h_T = 5 cm, theta_T = 3 deg, theta_max = 10 deg). ROS-free.
//
// Determinism: the only random source is std::mt19937_64 (its output sequence is fixed by the
// standard); uniform and normal variates are computed here from its raw output (the standard
// distributions are implementation-defined). Coordinates are rounded to 0.1 mm before use, so
// the same seed and config give byte-identical YAML on every run and machine (barring a libm
// that rounds sin/cos/atan2 differently exactly at a 0.1 mm boundary).
#pragma once

#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/scene_loader.h"

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

/// What a cell or a hazard item is to a wheelchair, for error rates broken down by hazard. The
/// class says what the surface or solid is (its role in the item), not whether it is safe: a
/// 3 cm curb's street is kDropOff but GT-safe (reachable, step < h_T), the landing of a 5 deg
/// ramp is kStepUp but GT-safe (reached by the ramp). Combine it with the GT label.
enum class HazardClass : std::uint8_t {
  kNone = 0,    ///< the base floor (start level), or no item
  kDropOff,     ///< ground lower than the start level: a curb's street, a pit's or light well's
                ///< floor, the yard below a platform edge or loading dock, the steps of a stair
                ///< down, the area at the foot of a ramp down
  kStepUp,      ///< level ground higher than the start level: a step, the sidewalk beyond a curb
                ///< up, the landing of a ramp up
  kSteepRamp,   ///< a sloped surface steeper than theta_max (000 Alg. 2 step 2: 10 deg)
  kGentleRamp,  ///< a sloped surface of at most theta_max (Level below theta_T = 3 deg, Inclined
                ///< above, 000 Alg. 2 step 28): ramps, curb cuts, flares
  kObstacle,    ///< a non-ground solid standing on the ground (poles, bollards, legs, low
                ///< obstacles, walls, railings)
  kOverhang,    ///< a non-ground solid whose underside is above the ground clearance (table tops,
                ///< shelves): free space under it, a collision at robot height
};
constexpr int kHazardClassCount = 7;

/// "none", "drop_off", "step_up", "steep_ramp", "gentle_ramp", "obstacle", "overhang".
const char* toString(HazardClass c);
bool parseHazardClass(const std::string& s, HazardClass* c);

/// One ground entry of a hazard item and the class of the cells whose top ground it is.
struct HazardPart {
  std::string entry;  ///< scene-file entry name (= Primitive::group of its solids)
  HazardClass cls = HazardClass::kNone;
};

/// One hazard of a procedural scene. `kind` and the meaning of `size`:
///   curb_down, curb_up, step_down, step_up: height of the step [m] (a curb is a straight edge
///     across the area, a step a rectangular platform or sunken area);
///   curb_cut_down, curb_cut_up: slope of the cut's ramp [deg] (a curb of 8-20 cm with a ramp cut
///     into it perpendicular to the edge and a sloped triangular flare on each side);
///   ramp_up, ramp_down: slope [deg] (a ramp to a landing, or down to a lower area);
///   platform_edge, loading_dock, pit, light_well: depth of the drop [m];
///   stairs_down: depth of the stair's foot [m] (3-6 steps of 15-18 cm in a stairwell);
///   pole, bollard (round or square): width [m]; legs: leg diameter [m] (1-4 thin legs alone);
///   table, shelf: height of the top surface [m] (tops on thin legs; a board on a wall);
///   kerb_stone, box, bag: height [m] (low obstacles 5-15 cm);
///   wall: height [m]; doorway: width of the gap [m] (a wall with a 0.8-1.2 m gap).
struct HazardItem {
  HazardClass cls = HazardClass::kNone;  ///< the item's main class (a ramp's by its slope)
  /// Entry-name prefix: the item's scene-file entries are named `group` or `group_<part>`, so
  /// Primitive::group (the entry name) ties solids to the item.
  std::string group;
  std::string group_kind;  ///< coarse family: curb, step, ramp, drop, pole, overhang, legs, low,
                           ///< wall
  std::string kind;
  double size = 0.0;                                   ///< see above
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< centre, or the point of an edge
                                                       ///< nearest the trajectory [m]
  std::string description;
  std::vector<HazardPart> parts;  ///< ground entries and their classes (none for obstacles)
  /// Smallest distance between the robot footprint along the trajectory and the item's
  /// footprint (everything of it that is not start-level ground) [m]; passes beside obstacles
  /// are placed at ProceduralConfig::pass_clearance_min..max.
  double clearance = 0.0;
  int frames_seen = 0;  ///< frames in which the left camera sees a point of it (1-6 m, unoccluded)
};

/// The robot's footprint for the trajectory check: a rectangle `length` along the heading and
/// `width` across, base_link `base_to_rear` ahead of its rear edge (a powered wheelchair with
/// footrests: 0.7 x 1.2 m, drive axle 0.3 m from the back).
struct FootprintConfig {
  double width = 0.7;         ///< [m], in (0, 3]
  double length = 1.2;        ///< [m], in (0, 3]
  double base_to_rear = 0.3;  ///< [m], in [0, length]
  double robot_height = 1.5;  ///< solids higher above the start level are driven under (000
                              ///< Sec. V-A) [m], in (0, 5]
  double clearance = 0.02;    ///< solids lower than this above the start level are driven over,
                              ///< as GroundTruthConfig::clearance [m], in [0, robot_height)
  double ground_tolerance = 0.01;  ///< ground under the footprint must be within this of the
                                   ///< start level (no curb, step, drop or ramp) [m], in (0, h_T)
  std::string validate() const;
};

/// Ranges of the generator. Every range is [min, max]; probabilities and weights are >= 0.
struct ProceduralConfig {
  double duration_s = 12.0;  ///< trajectory length [s], in [2, 600]
  double rate_hz = 10.0;     ///< camera frame rate [Hz], in (0, 100]
  int min_items = 2;         ///< hazard items per scene, 1 <= min <= max <= 8
  int max_items = 5;
  /// Driving speed of each drive [m/s] (a powered wheelchair indoors and on sidewalks).
  double speed_min = 0.2;
  double speed_max = 0.8;
  double reverse_speed_max = 0.4;   ///< reversing is slower [m/s]
  double turn_rate_min_deg = 20.0;  ///< in-place turn rate of a scene [deg/s]
  double turn_rate_max_deg = 45.0;
  /// Lateral clearance of passes beside obstacles: from the footprint's side to the obstacle [m].
  double pass_clearance_min = 0.3;
  double pass_clearance_max = 1.5;
  /// Nothing but start-level ground comes closer to the footprint than this anywhere [m].
  double min_clearance = 0.3;
  /// Stereo head: mount height [m] and downward pitch [deg]; other values are StereoHeadConfig's.
  double mount_z_min = 0.9;
  double mount_z_max = 1.3;
  double pitch_min_deg = 15.0;
  double pitch_max_deg = 30.0;
  double indoor_probability = 0.5;
  /// Step and curb heights: a mixture, `step_near_h_t_weight` of them in [0.03, 0.07] m around
  /// h_T = 5 cm (000 Alg. 2 step 17), the others in [step_min, step_max].
  double step_min = 0.03;
  double step_max = 0.20;
  double step_near_h_t_weight = 0.4;
  /// Ramp slopes: a mixture of [1, 5] deg around theta_T = 3 deg (000 Alg. 2 step 28), [8, 12]
  /// deg around theta_max = 10 deg (step 2) and the rest in [slope_min, slope_max].
  double slope_near_theta_t_weight = 0.4;
  double slope_near_theta_max_weight = 0.4;
  double slope_min_deg = 2.0;
  double slope_max_deg = 15.0;
  /// Hazard kinds and their relative weights (names as HazardItem::kind; the low obstacles
  /// kerb_stone, box, bag). Missing kinds are never drawn.
  std::map<std::string, double> kind_weights = defaultKindWeights();
  /// Visibility: at least this share of the frames sees some hazard, and every hazard is seen
  /// in at least `min_item_frames` frames (left camera, 1-6 m, in the image, unoccluded).
  double min_view_fraction = 0.5;
  int min_item_frames = 3;
  double area_margin = 4.0;     ///< the area extends this far around the trajectory [m], >= 2
  double area_min_size = 10.0;  ///< and is at least this wide and long [m]
  int max_attempts = 100;       ///< whole scenes tried before giving up, in [1, 10000]
  FootprintConfig footprint;

  static std::map<std::string, double> defaultKindWeights();
  std::string validate() const;
};

/// A generated scene.
struct ProceduralScene {
  std::uint64_t seed = 0;
  std::string yaml;  ///< the scene file text; loadSceneFromString(yaml, "", &f) gives `file`
  SceneFile file;    ///< scene, camera, trajectory, seed
  std::vector<HazardItem> hazards;
  std::string floor_kind;  ///< one of floorKinds()
  bool indoor = false;
  int attempts = 0;            ///< scenes tried (1 = the first was accepted)
  double view_fraction = 0.0;  ///< share of the frames that see some hazard
};

/// Base floor kinds and their material ranges (contrast = relative albedo modulation, grain =
/// centimetre-scale roughness, see Material):
///   polished: plain, or noise 0.5-2 m with contrast <= 0.03; grain <= 0.005 (stone, lacquer)
///   matt:     noise 0.3-1 m, contrast 0.03-0.08, grain 0.005-0.02 (vinyl, linoleum, paint)
///   carpet:   noise 0.05-0.2 m, contrast 0.08-0.2, grain 0.06-0.12 of 4-8 mm
///   tiles:    tiles 0.2-0.6 m, contrast 0.04-0.15, grout 1.5-5 %, grain <= 0.03
///   concrete: noise 0.3-1.5 m, contrast 0.06-0.15, grain 0.02-0.06
///   paving:   bricks or tiles 0.1-0.3 m, contrast 0.1-0.3, joints 4-10 %, grain 0.03-0.08
///   asphalt:  speckle 0.1-0.4 m, contrast 0.2-0.4, grain 0.05-0.1
/// Indoor scenes draw from polished, matt, carpet, tiles, concrete; outdoor ones from concrete,
/// paving, asphalt, tiles.
const std::vector<std::string>& floorKinds();
/// Every hazard kind the generator knows (the keys of defaultKindWeights()).
std::vector<std::string> hazardKinds();

/// Generates the scene of `seed`: tries whole scenes (trajectory first, hazards placed around
/// it, YAML emitted and parsed, checkTrajectoryClear, visibility) until one passes, at most
/// config.max_attempts. Returns an error message (empty on success); `out` is valid only on
/// success.
std::string generateProceduralScene(std::uint64_t seed, const ProceduralConfig& config,
                                    ProceduralScene* out);

/// Checks that the trajectory of `file` never drives into anything: samples it every 2 cm and
/// 1 deg (and at its end) and reports the first pose where the footprint overlaps a non-ground
/// solid between clearance and robot_height above the start level (the cylinder of a pole, the
/// box of a wall...), or covers a point (4 cm lattice incl. the border) whose ground is missing or
/// not within ground_tolerance of the start level base_z (a curb, step, drop or ramp). Empty when
/// clear.
std::string checkTrajectoryClear(const SceneFile& file, const FootprintConfig& footprint);

/// Hazard class of every cell of a GT map (same indexing as GroundTruthMap). Obstacle cells: the
/// class of the non-ground solid standing there, found with the GT's own test (a lattice of
/// vertical segments from ground + clearance to ground + robot_height): kObstacle when it reaches
/// down to ground + clearance at some sample of the cell (a leg, a pole, a wall), otherwise
/// kOverhang (only the underside of a table top or shelf is above the cell). Where both stand,
/// kObstacle wins. Other cells: the class of the hazard part whose entry the cell's top ground
/// belongs to (HazardItem::parts), kNone for the base floor, start-level scenery or no ground.
/// `config` must be the one the GT was computed with (robot height, clearance, samples).
std::vector<HazardClass> hazardClassMap(const ProceduralScene& scene, const GroundTruthMap& gt,
                                        const GroundTruthConfig& config = GroundTruthConfig());

/// One line: seed, look, floor kind, camera, frames, view share, hazards (kind size class).
std::string proceduralSummary(const ProceduralScene& scene);

}  // namespace dataset
}  // namespace stereo_safety_map
