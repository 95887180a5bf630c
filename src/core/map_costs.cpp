#include "stereo_safety_map/core/map_costs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <system_error>

namespace stereo_safety_map {

namespace fs = std::filesystem;

std::string CostTable::validate() const {
  std::ostringstream os;
  if (level < 0 || level > kMaxGraded) {
    os << "cost_level = " << level << ", must be in [0, 99] (below lethal: Level is safe)";
  } else if (inclined_low < level || inclined_low > kMaxGraded) {
    os << "cost_inclined_low = " << inclined_low << ", must be in [cost_level, 99] = [" << level
       << ", 99]";
  } else if (inclined_high < inclined_low || inclined_high > kMaxGraded) {
    os << "cost_inclined_high = " << inclined_high << ", must be in [cost_inclined_low, 99] = ["
       << inclined_low << ", 99] (graded Inclined stays below lethal)";
  } else if (drop_off < 1 || drop_off > kLethal) {
    os << "cost_drop_off = " << drop_off << ", must be in [1, 100]";
  }
  return os.str();
}

std::int8_t cellCost(const CostTable& table, SafetyLabel label, bool drop_off, double slope_deg,
                     double level_slope_deg, double max_slope_deg) {
  switch (label) {
    case SafetyLabel::kLevel:
    case SafetyLabel::kInclined:
      // 000 Sec. I-A / VI: safe cells annotated as potential drop-off edges.
      if (drop_off) return static_cast<std::int8_t>(table.drop_off);
      if (label == SafetyLabel::kLevel) return static_cast<std::int8_t>(table.level);
      {
        // Inclined: linear in the plane's slope between theta_T and theta_max (000 Alg. 2
        // step 28 labels a safe plane Inclined above theta_T; step 2 makes it Non-ground above
        // theta_max).
        double t = 0.0;
        if (std::isfinite(slope_deg) && max_slope_deg > level_slope_deg) {
          t = std::clamp((slope_deg - level_slope_deg) / (max_slope_deg - level_slope_deg), 0.0,
                         1.0);
        }
        return static_cast<std::int8_t>(
            std::lround(table.inclined_low + t * (table.inclined_high - table.inclined_low)));
      }
    case SafetyLabel::kNonGround:
      return static_cast<std::int8_t>(CostTable::kLethal);
    case SafetyLabel::kUnknown:
    case SafetyLabel::kUnexamined:
    default:
      return static_cast<std::int8_t>(CostTable::kUnknown);
  }
}

void safetyMapCosts(const SafetyMap& map, const CostTable& table, double level_slope_deg,
                    double max_slope_deg, std::vector<std::int8_t>* out) {
  const std::size_t n = map.labels.size();
  out->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int s = i < map.segment.size() ? map.segment[i] : -1;
    const double slope = (s >= 0 && s < static_cast<int>(map.segments.size()))
                             ? map.segments[s].plane.slope_deg
                             : 0.0;
    const bool drop = i < map.drop_off.size() && map.drop_off[i] != 0;
    (*out)[i] = cellCost(table, map.labels[i], drop, slope, level_slope_deg, max_slope_deg);
  }
}

std::string costsToRawPgm(const std::vector<std::int8_t>& costs, int width, int height) {
  if (width <= 0 || height <= 0 ||
      costs.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    return {};
  }
  std::ostringstream header;
  header << "P5\n# stereo_safety_map safety map costs (map_server mode: raw; 255 = unknown)\n"
         << width << " " << height << "\n255\n";
  std::string out = header.str();
  const std::size_t start = out.size();
  out.resize(start + costs.size());
  for (int r = 0; r < height; ++r) {
    const int row = height - 1 - r;  // image row 0 is the map's top (largest y)
    for (int c = 0; c < width; ++c) {
      out[start + static_cast<std::size_t>(r) * width + c] = static_cast<char>(
          static_cast<unsigned char>(costs[static_cast<std::size_t>(row) * width + c]));
    }
  }
  return out;
}

std::string rawPgmToCosts(const std::string& pgm, std::vector<std::int8_t>* costs, int* width,
                          int* height) {
  std::istringstream is(pgm);
  std::string magic;
  is >> magic;
  if (magic != "P5") return "not a binary PGM (P5)";
  is >> std::ws;
  while (is.peek() == '#') {
    std::string comment;
    std::getline(is, comment);
    is >> std::ws;
  }
  int w = 0, h = 0, maxval = 0;
  is >> w >> h >> maxval;
  if (!is || w <= 0 || h <= 0 || maxval != 255) return "bad PGM header";
  is.get();  // the single whitespace before the pixels
  const auto start = static_cast<std::size_t>(is.tellg());
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (pgm.size() != start + n) return "PGM pixel data of the wrong size";
  costs->resize(n);
  for (int r = 0; r < h; ++r) {
    const int row = h - 1 - r;
    for (int c = 0; c < w; ++c) {
      (*costs)[static_cast<std::size_t>(row) * w + c] = static_cast<std::int8_t>(
          static_cast<unsigned char>(pgm[start + static_cast<std::size_t>(r) * w + c]));
    }
  }
  if (width) *width = w;
  if (height) *height = h;
  return {};
}

void lethalCellPoints(const SafetyMap& map, const std::vector<std::int8_t>& costs, float z,
                      std::vector<Eigen::Vector3f>* out) {
  out->clear();
  if (costs.size() != static_cast<std::size_t>(std::max(map.width, 0)) * std::max(map.height, 0))
    return;
  for (int r = 0; r < map.height; ++r) {
    for (int c = 0; c < map.width; ++c) {
      if (costs[static_cast<std::size_t>(r) * map.width + c] < CostTable::kLethal) continue;
      const Eigen::Vector2d xy = map.cellCenter(map.min_u + c, map.min_v + r);
      out->emplace_back(static_cast<float>(xy.x()), static_cast<float>(xy.y()), z);
    }
  }
}

unsigned char staticLayerCost(std::int8_t value, const StaticLayerSettings& s) {
  // StaticLayer::interpretValue(unsigned char value), with its int parameters stored as
  // unsigned char (unknown_cost_value -1 -> 255).
  const auto v = static_cast<unsigned char>(value);
  const auto unknown = static_cast<unsigned char>(s.unknown_cost_value);
  const auto lethal = static_cast<unsigned char>(s.lethal_cost_threshold);
  if (s.track_unknown_space && v == unknown) return kCostmapNoInformation;
  if (!s.track_unknown_space && v == unknown) return kCostmapFreeSpace;
  if (v >= lethal) return kCostmapLethal;
  if (s.trinary_costmap) return kCostmapFreeSpace;
  const double scale = static_cast<double>(v) / lethal;
  return static_cast<unsigned char>(scale * kCostmapLethal);
}

namespace {

// true when `inner` is `outer` or below it (both absolute and normalised).
bool isInside(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // a trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

}  // namespace

std::string resolveSavePrefix(const std::string& directory, const std::string& prefix,
                              std::string* resolved) {
  const fs::path dir(directory);
  if (directory.empty() || !dir.is_absolute()) {
    return "save_directory '" + directory + "' must be an absolute path";
  }
  if (prefix.empty()) return "empty path prefix";
  const fs::path p(prefix);
  const fs::path full = (p.is_absolute() ? p : dir / p).lexically_normal();
  const fs::path name = full.filename();
  if (name.empty() || name == "." || name == "..") {
    return "path prefix '" + prefix + "' has no file name (e.g. " + (dir / "map").string() + ")";
  }
  std::error_code ec;
  // weakly_canonical follows the symlinks of the part of the path that exists.
  const fs::path base = fs::weakly_canonical(dir, ec);
  if (ec) return "cannot resolve save_directory '" + directory + "': " + ec.message();
  const fs::path parent = fs::weakly_canonical(full.parent_path(), ec);
  if (ec) return "cannot resolve '" + full.parent_path().string() + "': " + ec.message();
  if (!isInside(parent, base)) {
    return "refused: path prefix '" + prefix + "' resolves to " + (parent / name).string() +
           ", outside save_directory " + base.string() +
           " (absolute paths elsewhere, '..' and "
           "symlinks out of it are refused)";
  }
  *resolved = (parent / name).string();
  return {};
}

}  // namespace stereo_safety_map
