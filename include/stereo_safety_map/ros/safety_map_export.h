// ~save of the safety-map nodelet (SafetyMapRos::saveSrv): the files made from one state of the
// map, and writing them so that a reader never sees a half-written set.
//   <prefix>.bt          the 3D model (paper 000 Sec. IV-V) as an OctoMap;
//   <prefix>.pgm, .yaml  the safety map (000 Sec. VI) for map_server in `mode: raw`, each pixel
//                        the live OccupancyGrid's value (core/map_costs.h);
//   <prefix>_labels.png  a colour picture with 000 Fig. 4(a)'s colours.
#pragma once

#include "stereo_safety_map/core/map_costs.h"
#include "stereo_safety_map/core/safety_mapper.h"

#include <string>
#include <vector>

namespace stereo_safety_map {

/// A file of ~save: its final path, the temporary one it is written to first, its bytes.
struct SaveFile {
  std::string path;
  std::string tmp;
  std::string bytes;
};

/// The prefix a ~save request writes to: `requested` resolved under `directory`
/// (resolveSavePrefix), its parent directories created, and checked again once they exist, so
/// that a symlink made in between is seen. Empty on success (`*prefix` set), else a message.
std::string prepareSavePrefix(const std::string& directory, const std::string& requested,
                              std::string* prefix);

/// The bytes of ~save's files for the mapper's current state (`fixed_frame` is named in the
/// YAML). Empty on success, else a message (no map yet, OctoMap could not serialise).
std::string makeSaveFiles(const SafetyMapper& mapper, const CostTable& costs,
                          const std::string& fixed_frame, const std::string& prefix,
                          std::vector<SaveFile>* files);

/// Writes every file to its temporary name, then renames them all: a reader never sees a
/// half-written file, and the set is replaced at once (but for the few renames). On failure the
/// temporary files are removed and the message says what failed; empty on success.
std::string writeFilesAtomically(std::vector<SaveFile>* files);

}  // namespace stereo_safety_map
