#include "stereo_safety_map/core/safety_map.h"

namespace stereo_safety_map {

const char* toString(SafetyLabel l) {
  switch (l) {
    case SafetyLabel::kUnexamined:
      return "Unexamined";
    case SafetyLabel::kUnknown:
      return "Unknown";
    case SafetyLabel::kLevel:
      return "Level";
    case SafetyLabel::kInclined:
      return "Inclined";
    case SafetyLabel::kNonGround:
      return "Non-ground";
  }
  return "Invalid";
}

}  // namespace stereo_safety_map
