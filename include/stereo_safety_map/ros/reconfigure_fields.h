// dynamic_reconfigure and the field lists (core/param_fields.h): the live fields of a list are
// copied in from, and back to, a generated config (SafetyMapConfig, DisparityConfig) by name,
// through its dynamic_reconfigure::Config message (__toMessage__ / __fromMessage__), so that a
// reconfigure callback never lists the fields itself. test_nodelet_params checks that every live
// field is in the .cfg with the same type, level, default and range, and the other way round.
#pragma once

#include "stereo_safety_map/core/param_fields.h"

#include <dynamic_reconfigure/Config.h>

#include <string>

namespace stereo_safety_map {

/// The parameter `name` of a dynamic_reconfigure message as a value of `type`; false when the
/// message has no such parameter of that type.
bool reconfigureValue(const dynamic_reconfigure::Config& msg, const std::string& name,
                      ParamType type, ParamValue* value);
/// Sets the parameter `name` (of the value's type) in the message; false when it has none.
bool setReconfigureValue(dynamic_reconfigure::Config* msg, const std::string& name,
                         const ParamValue& value);

/// Copies the live fields of `list` from the generated config `from` into `config`. Empty on
/// success, else the first field's refusal or the name of a live field the generated config
/// lacks.
template <typename Config, typename Generated>
std::string fromReconfigure(const Generated& from, const ParamFieldList<Config>& list,
                            Config* config) {
  dynamic_reconfigure::Config msg;
  from.__toMessage__(msg);
  for (const ParamField<Config>& f : list.fields()) {
    if (!f.info.live() || !f.set) continue;
    ParamValue value;
    if (!reconfigureValue(msg, f.info.name, f.info.type, &value)) {
      return f.info.name + " is live but not in the reconfigure config";
    }
    const std::string why = f.set(config, value);
    if (!why.empty()) return why;
  }
  return "";
}

/// Writes the live fields of `list` from `config` into the generated config `to` (the values
/// handed back to the server, and so to rqt_reconfigure, after a refusal).
template <typename Config, typename Generated>
void toReconfigure(const Config& config, const ParamFieldList<Config>& list, Generated* to) {
  dynamic_reconfigure::Config msg;
  to->__toMessage__(msg);
  for (const ParamField<Config>& f : list.fields()) {
    if (f.info.live()) setReconfigureValue(&msg, f.info.name, f.get(config));
  }
  to->__fromMessage__(msg);
}

}  // namespace stereo_safety_map
