// 3D obstacle detection and segmentation in an organised range image (paper 003, Talukder,
// Manduchi, Rankin & Matthies 2002), ROS-free.
//
// Two surface points are "compatible" (003 Definition 1, Sec. 2) when their height difference
// lies in (H_T, H_max) and the line joining them is steeper than theta_T. A point is an obstacle
// point when some other visible point is compatible with it, and an obstacle is a connected
// component of the compatibility graph (003 Sec. 3). Heights are measured along gravity, i.e.
// along the z axis of the fixed frame given by T_fixed_camera, so a pitched or rolled camera (or
// a robot on a slope) needs no special case; this is what 003 Sec. 4.1 works around with a
// widened search window. Our window is the exact image bound of the compatibility cone for the
// actual camera pose (see computeWindows()), so no safety factor is needed.
//
// detect() scans the image bottom to top, left to right (OD Algorithm 2, 003 Sec. 2), labels
// with a label graph kept as a union-find forest (OS Algorithm 2, 003 Sec. 3) and applies the
// rule-based rejection of 003 Sec. 5. By default each point stops at its first partners
// (ObstacleDetectionConfig::exhaustive_search explains why and what changes);
// exhaustive_search = true is the paper's algorithm verbatim. detectColumnwise() is the
// column-wise baseline the paper compares against (003 Sec. 1 and 6): the same compatibility
// test, but only between points of the same image column, with 2D blob colouring for labels.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// Parameters of 003. The paper (written for a cross-country HMMWV) gives no values for H_T,
/// H_max and theta_T; ours are for a wheelchair, see each field.
struct ObstacleDetectionConfig {
  // --- Definition 1 (003, Sec. 2) ---
  /// H_T [m]: the smallest rise that counts as an obstacle, i.e. the highest step the
  /// wheelchair rolls over. 0.05 m is paper 000's h_T for the same wheelchair (000 Alg. 2).
  double height_threshold = 0.05;
  /// H_max [m]: the largest height difference of a compatible pair. It bounds the search window
  /// (003 Sec. 3), and two obstacles whose visible ground gap exceeds 2 H_max / tan(theta_T) get
  /// different labels (003 Sec. 4, with the geometry of our slope convention; the early-exit
  /// search separates at least as well). 0.3 m keeps that gap (0.6 m) below a wheelchair's
  /// width, so every gap the chair fits through separates obstacles, and the ring of foot points
  /// around an obstacle (H_max / tan(theta_T) = 0.3 m) narrow. Objects floating more than H_max
  /// above the ground (table tops) are not linked to it (003 Sec. 3: "concertina wire").
  double max_height = 0.3;
  /// theta_T [deg], angle above the horizontal that the line joining a compatible pair must
  /// exceed. 003 writes the test as |dz| / |p2 - p1| > cos(theta_T), i.e. measures theta_T from
  /// the vertical; we take it from the horizontal as its text and Fig. 2 do, so the test is
  /// |dz| / |p2 - p1| > sin(theta_T). 45 deg: curbs, walls and furniture are far steeper, while
  /// ramps (000 allows up to 10 deg) and curb cuts stay well below; inclines between are paper
  /// 000's business (Inclined / Non-ground by plane slope).
  double slope_threshold_deg = 45.0;

  // --- Stereo noise margin (ours, with the stereo error model of 001 Sec. 4.1) ---
  /// k >= 0: a pair is compatible only when Definition 1 still holds after each of its points
  /// has moved k standard deviations of its stereo range error along its viewing ray, the way
  /// that makes the pair least steep. Stereo errors move a point along its ray (the depth
  /// sigma_Z = Z^2 sigma_d / (f b), 001 Sec. 4.1), so |P| sigma_Z / Z along the ray; its vertical
  /// and horizontal parts, combined over the two points as root sums of squares (s_z, s_xy),
  /// shrink the rise and widen the run: |dz| - k s_z > H_T and
  /// |dz| - k s_z > tan(theta_T) (|dxy| + k s_xy). At range two ground pixels a few rows apart
  /// whose depth errors cross pass 003's constant test (the rise is the rays' spread, the run
  /// the errors' difference); this margin grows with Z^2 where the constants do not. 0 = off,
  /// 003's Definition 1 as written. Needs the stereo baseline (detect()'s `baseline`); without
  /// it (an organised cloud of unknown origin) the margin is off. 1: on the open-world dev split
  /// (20 scenes, default degradations) the false obstacles per frame fall from 20.6 to 0.7, the
  /// raised points' precision rises from 71.5 to 82.8 %, the per-frame recall of the obstacles in
  /// view falls from 90.9 to 81.7 % (2: 0.2 false obstacles, 63 % recall; README, "Obstacle cue").
  double noise_sigmas = 1.0;
  /// sigma_d [px] of the margin above: the disparity error's standard deviation (001 Sec. 4.1;
  /// the landmark filter's landmark_sigma_disparity default).
  double disparity_sigma = 0.5;

  // --- Search (003 Sec. 2 and 4.1) ---
  /// true: OD Algorithm 2 exactly as 003 Sec. 2 writes it: every pixel tests *all* points of its
  /// upper window U_p (sample_spacing and max_candidates_per_pixel do not apply), so every pair
  /// of the double window is tested once and the labels are the connected components of the
  /// compatibility graph (OS Algorithm 2). Its cost grows with the number of compatible pairs,
  /// i.e. with the obstacle area; 003 Sec. 2 itself notes that it only pays off when obstacles
  /// are sparse. A reference mode: ~60x slower on bench_obstacle_detection.
  /// false (default): each point searches its double window (the two triangles of OD Algorithm
  /// 1) for its first partner below it in 3D and, only if it has none and no other point has
  /// found it, for its first partner above it. The marks (obstacle / raised) are those of
  /// Definition 1 as with true (every point decides its own), the work per point is small even
  /// where obstacles are dense (003 Sec. 2: ~1 / alpha tests per obstacle point), and the labels
  /// come from the links found plus surface links (below). They can only split obstacles that
  /// the exhaustive search joins through a shared foot point.
  bool exhaustive_search = false;
  /// Early-exit search: false skips the search of a partner above for points that have none
  /// below (the feet of obstacles). Feet are then only those that raised points picked as their
  /// partner, a subset of Definition 1's; raised points and their labels do not change, and
  /// detect() takes ~40 % less time on bench_obstacle_detection. true marks every foot point,
  /// as the paper does.
  bool search_foot_points = true;
  /// Early-exit search: spacing [m] at the point's depth between the tested pixels of the
  /// window, on a lattice of stride max(1, sample_spacing * f / Z) pixels. 0 tests every pixel.
  /// Below H_T / 2 every rise of H_T is still sampled at least twice, and the work per pixel
  /// no longer depends on the depth.
  double sample_spacing = 0.02;
  /// Early-exit search: upper bound on the pixels of one double window that are tested; the
  /// stride grows when the window would hold more (points close to the camera). 0 = no bound.
  /// With it the work per pixel is bounded whatever the scene: linear in the number of pixels.
  int max_candidates_per_pixel = 1024;
  /// Early-exit search only: raised points that are 4-neighbours in the image and closer in 3D
  /// than max(surface_link_distance, surface_link_pixels * Z / f), capped at the foot reach
  /// H_max / tan(theta_T), share a label: the surface between them is continuous, and these
  /// links stand in for the pairs the search no longer visits. The second term follows the
  /// pixel footprint, which grazing views stretch (a curb top at 6 m is ~6 cm per pixel). Both
  /// stay below the depth gap between objects that only touch in the image (003 Fig. 6).
  /// surface_link_distance = 0 disables the links.
  double surface_link_distance = 0.05;  ///< [m]
  double surface_link_pixels = 8.0;     ///< [pixel footprints]

  // --- Segmentation, OS Algorithm 2 (003 Sec. 3) ---
  /// false: only the obstacle mask (OD Algorithm 2), no labels, no per-obstacle measures.
  bool segment = true;

  // --- Rule-based rejection of false obstacles (003 Sec. 5) ---
  /// Evaluate the rules below; rejected obstacles keep their label but leave the mask.
  bool reject_false_obstacles = true;
  /// 003 Sec. 5 example: "average slope lesser than 2.5 ... rejected". The paper gives no unit;
  /// we read degrees. With Definition 1 every obstacle point has a slope above theta_T, so this
  /// rule only bites when theta_T is set below it.
  double min_avg_slope_deg = 2.5;
  /// 003 Sec. 5 example: "maximum slope lesser than 5.0" (degrees, as above).
  double min_max_slope_deg = 5.0;
  /// Minimum mean height of the raised points above the obstacle's ground [m]; 0 disables
  /// (the paper gives no value).
  double min_avg_height = 0.0;
  /// Minimum height of the obstacle's top above its ground [m]; 0 disables (no paper value;
  /// it is above H_T by construction).
  double min_max_height = 0.0;
  /// Minimum perimeter of the 3D bounding box (003 Sec. 5 names it without defining it; we take
  /// the total edge length 4 (dx + dy + dz)) [m]; 0 disables (no paper value).
  double min_bbox_perimeter = 0.0;
  /// Minimum bounding volume [m^3] (003 Sec. 5 "small bounding volume"): the larger horizontal
  /// side of the raised points' box, squared, times the obstacle's height (the larger side
  /// rather than the footprint area, so that a thin post of which only a sliver is seen keeps
  /// its volume). 2.5e-4 m^3 (a 6.3 cm cube) rejects stereo blobs of a few centimetres that
  /// hover over the ground while keeping posts and anything that can stop a castor.
  double min_volume = 2.5e-4;

  /// Empty when valid, otherwise a message naming the first offending parameter and its range.
  std::string validate() const;
};

/// Why an obstacle was rejected by the rules of 003 Sec. 5 (first rule that fired).
enum class ObstacleRejection : std::uint8_t {
  kNone = 0,
  kSmallPerimeter,
  kLowAverageSlope,
  kLowMaxSlope,
  kLowAverageHeight,
  kLowMaxHeight,
  kSmallVolume,
};
const char* toString(ObstacleRejection r);

/// Measures of one segmented obstacle (003 Sec. 5). Positions are in the fixed frame (z up).
/// An obstacle's points are all points of its component, i.e. both ends of its compatible pairs:
/// the ground at its foot within H_max / tan(theta_T) belongs to it (Definition 1). "Raised"
/// points are those that are the upper end of at least one compatible pair.
struct ObstacleInfo {
  int label = 0;                                       ///< value in ObstacleDetectionResult::labels
  int pixel_count = 0;                                 ///< all points of the component
  int raised_count = 0;                                ///< upper ends of compatible pairs
  Eigen::Vector3f bbox_min = Eigen::Vector3f::Zero();  ///< axis-aligned box of all points
  Eigen::Vector3f bbox_max = Eigen::Vector3f::Zero();
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();  ///< of all points
  float ground_height = 0.0f;  ///< surrounding ground: lowest point of the component [m]
  float avg_height = 0.0f;     ///< mean height of the raised points above ground_height [m]
  float max_height = 0.0f;     ///< top of the obstacle above ground_height [m]
  /// Slopes of the compatible pairs found (all pairs of the window with exhaustive_search, the
  /// first ones otherwise): mean over points of their steepest pair, and the steepest [deg].
  float avg_slope_deg = 0.0f;
  float max_slope_deg = 0.0f;
  float bbox_perimeter = 0.0f;  ///< 4 (dx + dy + dz) of the box [m]
  float volume = 0.0f;  ///< (larger horizontal side of the raised points' box)^2 x max_height
  bool rejected = false;
  ObstacleRejection rejection = ObstacleRejection::kNone;
};

/// Output of one detection. Mats are reallocated only when the image size changes.
struct ObstacleDetectionResult {
  /// Mask values (CV_8U). Both non-zero values are obstacle points of 003 Definition 1.
  static constexpr std::uint8_t kNone = 0;
  static constexpr std::uint8_t kFoot = 128;    ///< only ever the lower end of its pairs
  static constexpr std::uint8_t kRaised = 255;  ///< upper end of at least one pair

  cv::Mat mask;    ///< CV_8U; points of rejected obstacles are kNone
  cv::Mat labels;  ///< CV_32S; 0 = none, else ObstacleInfo::label (rejected ones included);
                   ///< all 0 when segmentation is off
  std::vector<ObstacleInfo> obstacles;  ///< obstacles[i].label == i + 1
  int num_accepted = 0;                 ///< obstacles not rejected

  std::size_t valid_points = 0;      ///< finite points in front of the camera
  std::size_t pairs_tested = 0;      ///< Definition 1 evaluations
  std::size_t compatible_pairs = 0;  ///< of which compatible
  std::string error;                 ///< why detect() returned false, else empty
};

/// Focal length [px] of the pinhole camera behind an organised range image (CV_32FC3, camera
/// optical frame), for inputs that come without a CameraInfo (an organised PointCloud2): the
/// least-squares fit of the column u against x / z over the valid pixels (u = f x / z + c_x).
/// 0 when fewer than 100 pixels are valid or they span less than 10 columns.
double estimateFocalLength(const cv::Mat& range_image);

/// The range image at 1/factor of its resolution, for detect() at a lower cost (ours, issue 18:
/// the detector's share of a 30 Hz graph on two cores): pixel (i, j) is the source's (factor i,
/// factor j), picked and not averaged (an average across a depth edge is a point on neither
/// surface). Give detect() focal_length / factor and baseline * factor: the noise margin depends
/// on the source disparity's f b (001 Sec. 4.1), which that keeps, and the windows on the
/// decimated pixel footprint. factor 1 copies nothing (dst shares src's data); factor < 1 or a
/// src that is not CV_32FC3 leaves dst empty. dst is reallocated only when its size changes.
void decimateRangeImage(const cv::Mat& src, int factor, cv::Mat* dst);

/// The raised points (upper ends of compatible pairs, ObstacleDetectionResult::kRaised) of the
/// accepted obstacles of `result`, taken from `range_image` (the one detect() was given) into
/// the fixed frame, with their labels, in image order: the obstacle cue of the safety map
/// (obstacle_cue.h). The feet are the ground around an obstacle and are left out. Clears both
/// vectors first; `labels` may be null.
void raisedObstaclePoints(const ObstacleDetectionResult& result, const cv::Mat& range_image,
                          const Eigen::Isometry3f& T_fixed_camera,
                          std::vector<Eigen::Vector3f>* points, std::vector<std::uint32_t>* labels);

/// OD Algorithm 2 + OS Algorithm 2 + Sec. 5 rules (003). Not thread-safe; one per thread.
/// Linear in the number of pixels: each pixel tests at most max_candidates_per_pixel others, and
/// 8x8 tiles (and 4x4-tile blocks) whose 3D bounds cannot hold a compatible pair are skipped as
/// a whole, so flat ground costs almost nothing. Buffers are members: once warmed up on an image
/// size and scene, detect() does not allocate (the obstacle list keeps the capacity of the
/// result it is given; lists grow only past their largest size so far).
class ObstacleDetector {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit ObstacleDetector(const ObstacleDetectionConfig& config = ObstacleDetectionConfig());

  const ObstacleDetectionConfig& config() const { return config_; }

  /// `range_image`: CV_32FC3 points in the camera optical frame (x right, y down, z forward),
  /// NaN / inf / z <= 0 = missing (e.g. from reprojectDisparityOrganized). `focal_length`: f in
  /// pixels (use max(fx, fy) when they differ). `T_fixed_camera`: camera -> a frame whose z axis
  /// points up (gravity from tf). Returns false, with an empty result and result->error set, on
  /// an empty image, a wrong type, a non-positive f or a non-rigid / non-finite pose.
  /// `baseline` [m]: the stereo baseline b behind the range image, for the noise margin
  /// (ObstacleDetectionConfig::noise_sigmas); 0 = unknown, no margin.
  bool detect(const cv::Mat& range_image, double focal_length,
              const Eigen::Isometry3f& T_fixed_camera, ObstacleDetectionResult* result,
              double baseline = 0.0);

  /// The column-wise baseline (003 Sec. 1, [Matthies96], [Bellutta00]): each column is a 1D
  /// range profile and only points of the same column are tested with Definition 1; labels are
  /// 8-connected blobs of the mask (2D blob colouring), measures and rules as in detect().
  bool detectColumnwise(const cv::Mat& range_image, double focal_length,
                        const Eigen::Isometry3f& T_fixed_camera, ObstacleDetectionResult* result,
                        double baseline = 0.0);

  /// Definition 1 (003, Sec. 2) for two points in the fixed frame (z up).
  bool compatible(const Eigen::Vector3f& a, const Eigen::Vector3f& b) const;

 private:
  struct Tile {
    float xmin, xmax, ymin, ymax, zmin, zmax;  // fixed frame bounds of the valid points
    float depth_min, depth_max;                // camera z range
    float rx_min, rx_max, ry_min, ry_max;      // ray slopes x/z, y/z
    int count;                                 // valid points
    float m_up, m_side;                        // window extents per unit f / depth (Sec. 4.1)
    float ez_min, eh_min;  // smallest noise-margin errors of its points (0 when the margin is off)
  };
  struct Candidate {  // a tile that may hold a partner: bounds and sampled pixels
    float xmin, xmax, ymin, ymax, zmin, zmax;
    int skip;              // > 0: header of the next `skip` entries (bounds = their union)
    int r0, r1;            // first and last sampled row, as row * cols
    int c0, c1;            // first sampled column, last column
    float ez_min, eh_min;  // smallest noise-margin errors of its points (0: margin off)
  };
  struct Accumulator {
    int count, raised;
    float min[3], max[3];
    double sum[3];
    float raised_min[2], raised_max[2];
    double raised_sum_z;
    double slope_sum;
    float max_tan2;
  };

  bool run(const cv::Mat& range_image, double focal_length, const Eigen::Isometry3f& T_fixed_camera,
           bool columnwise, double baseline, ObstacleDetectionResult* result);
  // The noise margin's test of a pair that passed Definition 1 (noise_sigmas).
  bool clearOfNoise(int ip, int iq, float dz, float h2) const {
    if (noise_scale_ <= 0.0f) return true;
    const float sz = std::sqrt(ez_[ip] * ez_[ip] + ez_[iq] * ez_[iq]);
    const float sh = std::sqrt(eh_[ip] * eh_[ip] + eh_[iq] * eh_[iq]);
    const float rise = std::fabs(dz) - sz;
    if (!(rise > ht_)) return false;
    const float run = std::sqrt(h2) + sh;
    return rise * rise > tan2_ * run * run;
  }
  std::size_t prepare(const cv::Mat& range_image, const Eigen::Isometry3f& T_fixed_camera);
  void computeWindows(float f, bool column_only);
  int windowPx(float m, float depth, int clip) const;
  int strideFor(float depth, int reach_rows, int reach_cols) const;
  template <bool kColumnOnly>
  void searchAllPairs(float f);
  template <bool kColumnOnly>
  void searchFirstPartner(float f);
  template <bool kBelow, bool kColumnOnly>
  bool findPartner(const std::vector<Candidate>& tiles, int* hint, int ip, int s);
  void surfaceLinks();
  Tile groupBounds(int tr, int tc) const;
  void linkPair(int ip, int iq, float dz, float h2, bool label);
  void blobLabels();
  void finalize(ObstacleDetectionResult* result);
  int newLabel();
  int findRoot(int l);
  void unite(int a, int b);

  ObstacleDetectionConfig config_;
  float ht_ = 0.0f, ht2_ = 0.0f, hmax_ = 0.0f, hmax2_ = 0.0f, tan2_ = 0.0f;

  int rows_ = 0, cols_ = 0, tiles_r_ = 0, tiles_c_ = 0;
  Eigen::Vector3f up_camera_ = Eigen::Vector3f::Zero();  // fixed-frame z in the camera frame
  std::vector<float> x_, y_, z_;                         // fixed frame, NaN = missing
  std::vector<float> depth_;                             // camera z, NaN = missing
  float noise_scale_ = 0.0f;    // k sigma_d / (f b) of this frame, 0 = no noise margin
  std::vector<float> ez_, eh_;  // per point: k x its ray error's vertical / horizontal part [m]
  std::vector<std::uint8_t> marks_;   // bit 0 obstacle point, bit 1 raised
  std::vector<float> steep_;          // per point: max tan^2 of its compatible pairs
  std::vector<std::int32_t> labels_;  // provisional labels (valid where marks_ != 0)
  std::vector<std::int32_t> parent_;  // label graph of OS Algorithm 2 as a union-find forest
  std::vector<std::int32_t> final_id_;
  std::vector<Tile> tiles_;
  std::vector<Tile> blocks_;  // kBlock x kBlock tiles: bounds for a coarse first pruning
  int blocks_r_ = 0, blocks_c_ = 0;
  std::vector<int> candidates_;
  std::vector<Candidate> below_tiles_, above_tiles_;
  float f_ = 0.0f, depth_margin_ = 0.0f;
  std::vector<Accumulator> acc_;
  std::size_t pairs_tested_ = 0, compatible_pairs_ = 0;
};

}  // namespace stereo_safety_map
