// Checks of a field list (core/param_fields.h) against its config, shared by
// test_param_fields (core lists), test/ros_unit/test_nodelet_params (the nodelets' lists) and the
// parameter rostests: every bound of a field's range is probed against the list's validation,
// and values for every field that the validation accepts.
#pragma once

#include "stereo_safety_map/core/param_fields.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>
#include <vector>

namespace param_field_checks {

using stereo_safety_map::ParamField;
using stereo_safety_map::ParamFieldList;
using stereo_safety_map::ParamInfo;
using stereo_safety_map::ParamType;
using stereo_safety_map::ParamValue;

inline bool isNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}

/// Position of `name` as a whole word in `text`, npos when absent.
inline std::size_t wordAt(const std::string& text, const std::string& name) {
  for (std::size_t at = text.find(name); at != std::string::npos; at = text.find(name, at + 1)) {
    const bool left = at == 0 || !isNameChar(text[at - 1]);
    const bool right = at + name.size() >= text.size() || !isNameChar(text[at + name.size()]);
    if (left && right) return at;
  }
  return std::string::npos;
}

/// The field a validation message is about: the one whose name comes first in it (messages
/// start with the offending parameter; later names are the bounds it is relative to).
inline std::string firstField(const std::string& message, const std::vector<std::string>& names) {
  std::string best;
  std::size_t best_at = std::string::npos;
  for (const std::string& n : names) {
    const std::size_t at = wordAt(message, n);
    if (at == std::string::npos) continue;
    if (best_at == std::string::npos || at < best_at || (at == best_at && n.size() > best.size())) {
      best = n;
      best_at = at;
    }
  }
  return best;
}

/// A numeric value as a ParamValue of `type` (ints rounded).
inline ParamValue numeric(ParamType type, double v) {
  if (type == ParamType::kInt) return ParamValue(static_cast<int>(std::lround(v)));
  return ParamValue(v);
}

/// Values just outside each finite bound of the field's numeric range, and the bounds that
/// belong to the range (closed sides).
struct Probes {
  std::vector<ParamValue> outside;
  std::vector<ParamValue> at_bound;
};

inline Probes probesOf(const ParamInfo& info) {
  Probes p;
  const auto& r = info.range;
  const bool is_int = info.type == ParamType::kInt;
  if (r.hasMin()) {
    const double step = is_int ? 1.0 : std::max(1e-6, 1e-3 * std::fabs(r.min));
    p.outside.push_back(numeric(info.type, r.min_open ? r.min : r.min - step));
    if (!r.min_open) p.at_bound.push_back(numeric(info.type, r.min));
  }
  if (r.hasMax()) {
    const double step = is_int ? 1.0 : std::max(1e-6, 1e-3 * std::fabs(r.max));
    p.outside.push_back(numeric(info.type, r.max_open ? r.max : r.max + step));
    if (!r.max_open) p.at_bound.push_back(numeric(info.type, r.max));
  }
  if (!r.choices.empty()) {
    for (const std::string& c : r.choices) {
      p.at_bound.push_back(is_int ? ParamValue(std::stoi(c)) : ParamValue(c));
    }
    if (is_int) {
      int above = 0;
      for (const std::string& c : r.choices)
        above = std::max(above, std::stoi(c) + 1);
      p.outside.push_back(ParamValue(above));
    } else {
      p.outside.push_back(ParamValue(std::string("not_a_choice")));
    }
  }
  return p;
}

/// Every numeric bound and choice of every field against the list's validation: a value just
/// outside the range is refused by a message naming the field (or by the field's own setter);
/// a closed bound, a choice, is accepted unless another field's relative bound refuses it. A
/// field whose range is shown as text (relative bounds) is probed outside its numeric range
/// only.
template <typename Config>
void expectRangesMatchValidation(const ParamFieldList<Config>& list, const std::string& what) {
  const std::vector<std::string> names = list.names();
  int probed = 0;
  for (const ParamField<Config>& f : list.fields()) {
    if (!f.set) continue;
    const Probes probes = probesOf(f.info);
    for (const ParamValue& v : probes.outside) {
      Config c{};
      std::string err = f.set(&c, v);
      if (err.empty()) err = list.validate(c);
      EXPECT_NE(err, "") << what << ": " << f.info.name << " = "
                         << stereo_safety_map::formatParamValue(v) << " is outside its range "
                         << f.info.range.describe(f.info.type) << " but accepted";
      EXPECT_NE(wordAt(err, f.info.name), std::string::npos)
          << what << ": " << f.info.name << " = " << stereo_safety_map::formatParamValue(v)
          << " refused with a message that does not name it: " << err;
      ++probed;
    }
    if (!f.info.range.text.empty()) continue;
    for (const ParamValue& v : probes.at_bound) {
      Config c{};
      std::string err = f.set(&c, v);
      if (err.empty()) err = list.validate(c);
      EXPECT_NE(firstField(err, names), f.info.name)
          << what << ": " << f.info.name << " = " << stereo_safety_map::formatParamValue(v)
          << " is in its range " << f.info.range.describe(f.info.type) << " but refused: " << err;
      ++probed;
    }
  }
  EXPECT_GT(probed, 0) << what << ": nothing to probe";
}

/// A value of the field that differs from `current` and that the list's validation accepts
/// (from small steps away from it, its bounds and its choices); false when none is found.
template <typename Config>
bool acceptedOtherValue(const ParamFieldList<Config>& list, const ParamField<Config>& f,
                        const Config& base, ParamValue* out) {
  const ParamValue current = f.get(base);
  std::vector<ParamValue> candidates;
  switch (f.info.type) {
    case ParamType::kBool:
      candidates.push_back(ParamValue(!std::get<bool>(current)));
      break;
    case ParamType::kInt: {
      const int v = std::get<int>(current);
      for (int d : {1, -1, 2, -2, 16, -16, 100})
        candidates.push_back(ParamValue(v + d));
      break;
    }
    case ParamType::kDouble: {
      const double v = std::get<double>(current);
      for (double x : {v * 1.5, v * 0.5, v + 0.25, v - 0.25, v + 1.0, 0.5})
        candidates.push_back(ParamValue(x));
      break;
    }
    case ParamType::kString:
      candidates.push_back(ParamValue(std::get<std::string>(current) + "_other"));
      break;
  }
  for (const ParamValue& v : probesOf(f.info).at_bound)
    candidates.push_back(v);
  for (const ParamValue& v : candidates) {
    if (v == current) continue;
    Config c = base;
    if (!f.set(&c, v).empty() || !list.validate(c).empty()) continue;
    *out = v;
    return true;
  }
  return false;
}

/// Every field's accessor stores what it is given and leaves the other fields alone.
template <typename Config>
void expectAccessorsRoundTrip(const ParamFieldList<Config>& list, const std::string& what) {
  const Config base{};
  for (const ParamField<Config>& f : list.fields()) {
    if (!f.set) continue;
    ParamValue v;
    ASSERT_TRUE(acceptedOtherValue(list, f, base, &v))
        << what << ": no accepted value for " << f.info.name << " besides its default";
    Config c = base;
    ASSERT_EQ(f.set(&c, v), "") << f.info.name;
    EXPECT_EQ(f.get(c), v) << what << ": " << f.info.name << " does not read back what it stored";
    std::vector<std::string> changed = stereo_safety_map::changedFields(list, base, c);
    EXPECT_EQ(changed, std::vector<std::string>{f.info.name})
        << what << ": setting " << f.info.name << " changed other fields too";
  }
}

}  // namespace param_field_checks
