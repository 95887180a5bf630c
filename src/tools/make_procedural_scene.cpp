// make_procedural_scene: writes procedural scene files (dataset/procedural_scene.h) for a range of
// seeds and prints a one-line summary per seed, so that a human can inspect the scenes and render
// them with make_dataset --scene. ROS-free.
//
//   make_procedural_scene --out DIR [--seed S | --first S --count N] [--duration S] [--rate HZ]
//                         [--items MIN-MAX] [--kinds k1,k2,...] [--indoor P] [--verbose]
//
// Writes DIR/procedural_<seed>.yaml. --kinds keeps only the listed hazard kinds (their default
// weights); --indoor sets the share of indoor scenes; --verbose adds one line per hazard (class,
// description, closest approach of the robot, frames in view). Exit code 1 when some seed fails.
#include "stereo_safety_map/dataset/procedural_scene.h"

#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace ds = stereo_safety_map::dataset;

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: make_procedural_scene --out DIR [--seed S | --first S --count N]\n"
               "           [--duration S] [--rate HZ] [--items MIN-MAX] [--kinds k1,k2,...]\n"
               "           [--indoor P] [--verbose]\n"
               "hazard kinds:");
  for (const std::string& k : ds::hazardKinds())
    std::fprintf(stderr, " %s", k.c_str());
  std::fprintf(stderr, "\n");
}

bool makeDir(const std::string& d) {
  if (mkdir(d.c_str(), 0775) == 0) return true;
  struct stat st;
  return stat(d.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool toNumber(const char* s, double* v) {
  char* end = nullptr;
  *v = std::strtod(s, &end);
  return end && *end == '\0' && end != s;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  unsigned long long first = 0, count = 1;
  bool verbose = false;
  ds::ProceduralConfig cfg;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const char* v = i + 1 < argc ? argv[i + 1] : nullptr;
    double x = 0.0;
    if (a == "--verbose" || a == "-v") {
      verbose = true;
      continue;
    }
    if (!v) {
      usage();
      return 2;
    }
    ++i;
    if (a == "--out") {
      out = v;
    } else if (a == "--seed" || a == "--first") {
      if (!toNumber(v, &x) || x < 0) return usage(), 2;
      first = static_cast<unsigned long long>(x);
    } else if (a == "--count") {
      if (!toNumber(v, &x) || x < 1) return usage(), 2;
      count = static_cast<unsigned long long>(x);
    } else if (a == "--duration") {
      if (!toNumber(v, &cfg.duration_s)) return usage(), 2;
    } else if (a == "--rate") {
      if (!toNumber(v, &cfg.rate_hz)) return usage(), 2;
    } else if (a == "--indoor") {
      if (!toNumber(v, &cfg.indoor_probability)) return usage(), 2;
    } else if (a == "--items") {
      if (std::sscanf(v, "%d-%d", &cfg.min_items, &cfg.max_items) != 2) return usage(), 2;
    } else if (a == "--kinds") {
      const auto all = ds::ProceduralConfig::defaultKindWeights();
      cfg.kind_weights.clear();
      std::stringstream ss(v);
      std::string k;
      while (std::getline(ss, k, ',')) {
        const auto f = all.find(k);
        cfg.kind_weights[k] = f != all.end() ? f->second : 1.0;  // validate() names unknown ones
      }
    } else {
      usage();
      return 2;
    }
  }
  const std::string e = cfg.validate();
  if (out.empty() || !e.empty()) {
    if (!e.empty()) std::fprintf(stderr, "error: %s\n", e.c_str());
    usage();
    return 2;
  }
  if (!makeDir(out)) {
    std::fprintf(stderr, "error: cannot create %s\n", out.c_str());
    return 1;
  }
  int failures = 0;
  for (unsigned long long seed = first; seed < first + count; ++seed) {
    ds::ProceduralScene sc;
    const std::string err = ds::generateProceduralScene(seed, cfg, &sc);
    if (!err.empty()) {
      std::fprintf(stderr, "error: %s\n", err.c_str());
      ++failures;
      continue;
    }
    const std::string path = out + "/" + sc.file.scene.name + ".yaml";
    std::ofstream f(path);
    f << sc.yaml;
    if (!f) {
      std::fprintf(stderr, "error: cannot write %s\n", path.c_str());
      ++failures;
      continue;
    }
    std::printf("%s -> %s\n", ds::proceduralSummary(sc).c_str(), path.c_str());
    if (verbose) {
      for (const ds::HazardItem& h : sc.hazards)
        std::printf("    %-22s %-11s %s; closest %.2f m, in view %d frames\n", h.group.c_str(),
                    ds::toString(h.cls), h.description.c_str(), h.clearance, h.frames_seen);
    }
  }
  return failures == 0 ? 0 : 1;
}
