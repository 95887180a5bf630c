// One declarative field list per configuration (ARCHITECTURE.md: "the ROS reader, YAML,
// dynamic_reconfigure and the README's parameter table derive from it").
//
// A field is a parameter as the nodelets and the offline tools name it (the flat key of
// config/*.yaml): its type, how to reach it in the config struct (a pointer to member through
// nested structs, or a getter / setter pair for values such as `matcher: bm | sgbm`), the range
// the config's validate() accepts, unit, a one-line doc that cites the paper or says "(ours)",
// and whether dynamic_reconfigure can change it at run time, at which level. The default is
// never written down here: it is the struct's own default member initialiser, read through the
// accessor from a default-constructed config.
//
// From one list:
//   - the ROS reader (ros/param_reader.h: readFields), with its messages naming the parameter;
//   - the names for the unknown-parameter warning (names());
//   - the YAML reader and `--set` of the offline tools (ros/param_yaml.h);
//   - dynamic_reconfigure's copy-in / copy-back / what-changed (ros/reconfigure_fields.h);
//   - the README's Parameters lists (markdownLine(), src/tools/param_table.cpp).
// The field list does not validate: validate() of the config stays the one place that decides,
// with its messages; the list's range is what those checks accept, for the documentation, the
// .cfg and the tests (test/core/test_param_fields.cpp probes every bound against validate()).
//
// ROS-free (test_no_ros_in_core), header only but for the formatting in param_fields.cpp.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace stereo_safety_map {

enum class ParamType { kBool, kInt, kDouble, kString };

/// A parameter's value. Always build strings as std::string (a const char* would become a bool).
using ParamValue = std::variant<bool, int, double, std::string>;

/// "bool", "int", "double", "string" (as the README and dynamic_reconfigure's str_t say them).
const char* paramTypeName(ParamType type);
ParamType paramTypeOf(const ParamValue& value);
/// true / false, 5, 0.1 (shortest %g form), inf, or the string itself.
std::string formatParamValue(const ParamValue& value);
/// A number as formatParamValue writes it.
std::string formatParamNumber(double value);

/// What validate() accepts for a field. Numeric bounds are absolute (the widest the field can
/// take; dynamic_reconfigure's min / max); a bound that depends on another field (occ_threshold
/// <= lop_max) is written in `text`, which the README shows instead of the numeric range.
struct ParamRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;  ///< (min, ...: min itself is refused
  bool max_open = false;  ///< ..., max): max itself is refused
  /// The only values allowed (strings such as "bm" / "sgbm", or integers such as "4" / "8").
  std::vector<std::string> choices;
  /// Shown instead of the generated range: relative bounds, "odd", "multiple of 16", ...
  std::string text;

  bool hasMin() const { return min > -std::numeric_limits<double>::infinity(); }
  bool hasMax() const { return max < std::numeric_limits<double>::infinity(); }
  /// "[1, 1000]", "(0, 10]", "> 0", ">= 0", "< 0", "`bm` | `sgbm`", "4 | 8", `text`, or "".
  std::string describe(ParamType type) const;
};

/// Everything about a field except how to reach it: what the README, the YAML check and the
/// .cfg check need.
struct ParamInfo {
  std::string name;  ///< parameter name: the flat key in config/*.yaml and in ~
  ParamType type = ParamType::kDouble;
  ParamValue default_value;  ///< filled by ParamFieldList::infos() from a default config
  ParamRange range;
  std::string unit;     ///< "m", "deg", "s", "px", ... (empty: none)
  std::string doc;      ///< one line, with the paper's section or "(ours)"
  std::string section;  ///< README sub-heading the field is listed under
  /// dynamic_reconfigure level (the .cfg's constant, e.g. STAGE = 1); 0 = read at start only.
  uint32_t level = 0;
  /// Read by a library, not by us (diagnostic_period: diagnostic_updater): documented and known
  /// to the unknown-parameter warning, never read into a config.
  bool external = false;

  bool live() const { return level != 0; }
};

/// The README's line for a field:
/// "- `~name` (type, default unit, range) [live]: doc".
std::string markdownLine(const ParamInfo& info);
/// The README's list for some fields: "Section:" lines, their fields, a blank line between
/// sections.
std::string markdownList(const std::vector<ParamInfo>& infos);

template <typename Config>
struct ParamField {
  ParamInfo info;
  std::function<ParamValue(const Config&)> get;
  /// Stores a value of info.type; empty when accepted, else why not (an unknown enum name).
  /// Null for external fields.
  std::function<std::string(Config*, const ParamValue&)> set;

  // Builders, chained after ParamFieldList::add(): .closed(0, 10).unit("m").doc("...").
  ParamField& closed(double lo, double hi) { return bounds(lo, false, hi, false); }
  ParamField& openClosed(double lo, double hi) { return bounds(lo, true, hi, false); }
  ParamField& closedOpen(double lo, double hi) { return bounds(lo, false, hi, true); }
  ParamField& open(double lo, double hi) { return bounds(lo, true, hi, true); }
  ParamField& above(double lo) { return bounds(lo, true, kInf, false); }     ///< > lo
  ParamField& atLeast(double lo) { return bounds(lo, false, kInf, false); }  ///< >= lo
  ParamField& below(double hi) { return bounds(-kInf, false, hi, true); }    ///< < hi
  ParamField& atMost(double hi) { return bounds(-kInf, false, hi, false); }  ///< <= hi
  ParamField& oneOf(std::vector<std::string> choices) {
    info.range.choices = std::move(choices);
    return *this;
  }
  ParamField& rangeText(std::string text) {
    info.range.text = std::move(text);
    return *this;
  }
  ParamField& unit(std::string u) {
    info.unit = std::move(u);
    return *this;
  }
  ParamField& doc(std::string d) {
    info.doc = std::move(d);
    return *this;
  }
  ParamField& live(uint32_t level) {
    info.level = level;
    return *this;
  }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  ParamField& bounds(double lo, bool lo_open, double hi, bool hi_open) {
    info.range.min = lo;
    info.range.min_open = lo_open;
    info.range.max = hi;
    info.range.max_open = hi_open;
    return *this;
  }
};

namespace param_fields_detail {

template <typename T, typename M>
auto& follow(T& object, M member) {
  return object.*member;
}
template <typename T, typename M, typename... Ms>
auto& follow(T& object, M member, Ms... rest) {
  return follow(object.*member, rest...);
}

template <typename T>
constexpr ParamType typeOf() {
  static_assert(std::is_same<T, bool>::value || std::is_same<T, int>::value ||
                    std::is_same<T, double>::value || std::is_same<T, std::string>::value,
                "a parameter is a bool, an int, a double or a std::string");
  if (std::is_same<T, bool>::value) return ParamType::kBool;
  if (std::is_same<T, int>::value) return ParamType::kInt;
  if (std::is_same<T, double>::value) return ParamType::kDouble;
  return ParamType::kString;
}

}  // namespace param_fields_detail

/// The fields of one config struct, in the order they are read and documented.
template <typename Config>
class ParamFieldList {
 public:
  using Validator = std::function<std::string(const Config&)>;

  /// Fields added from now on are listed under this README heading.
  ParamFieldList& section(std::string title) {
    section_ = std::move(title);
    return *this;
  }

  /// A field stored in a member, reached through nested structs:
  /// add("voxel_size", &SafetyMapperConfig::grid, &VoxelGridConfig::voxel_size).
  template <typename... Members>
  ParamField<Config>& add(std::string name, Members... path) {
    using T = std::decay_t<decltype(param_fields_detail::follow(std::declval<Config&>(), path...))>;
    ParamField<Config> f;
    f.info.name = std::move(name);
    f.info.type = param_fields_detail::typeOf<T>();
    f.get = [path...](const Config& c) {
      return ParamValue(param_fields_detail::follow(c, path...));
    };
    f.set = [path...](Config* c, const ParamValue& v) {
      param_fields_detail::follow(*c, path...) = std::get<T>(v);
      return std::string();
    };
    return push(std::move(f));
  }

  /// A field computed from the config: `get` returns its value, `set` stores one and returns
  /// why not when it cannot (an unknown enum name). T is bool, int, double or std::string.
  template <typename T>
  ParamField<Config>& addAccessor(std::string name, std::function<T(const Config&)> get,
                                  std::function<std::string(Config*, const T&)> set) {
    ParamField<Config> f;
    f.info.name = std::move(name);
    f.info.type = param_fields_detail::typeOf<T>();
    f.get = [get](const Config& c) { return ParamValue(get(c)); };
    f.set = [set](Config* c, const ParamValue& v) { return set(c, std::get<T>(v)); };
    return push(std::move(f));
  }

  /// A parameter read by a library (diagnostic_updater's diagnostic_period): documented and a
  /// known name, never read into the config.
  ParamField<Config>& addExternal(std::string name, ParamValue default_value) {
    ParamField<Config> f;
    f.info.name = std::move(name);
    f.info.type = paramTypeOf(default_value);
    f.info.external = true;
    f.get = [default_value](const Config&) { return default_value; };
    return push(std::move(f));
  }

  /// Every field of `inner`, reached through `member` of this config; README sections and levels
  /// as in `inner`.
  template <typename Inner>
  ParamFieldList& include(const ParamFieldList<Inner>& inner, Inner Config::*member) {
    for (const ParamField<Inner>& f : inner.fields()) {
      ParamField<Config> g;
      g.info = f.info;
      auto get = f.get;
      g.get = [get, member](const Config& c) { return get(c.*member); };
      if (f.set) {
        auto set = f.set;
        g.set = [set, member](Config* c, const ParamValue& v) { return set(&(c->*member), v); };
      }
      fields_.push_back(std::move(g));
    }
    return *this;
  }

  /// The check the readers end with: validate() of the config, in parameter names.
  ParamFieldList& setValidator(Validator v) {
    validator_ = std::move(v);
    return *this;
  }
  std::string validate(const Config& c) const { return validator_ ? validator_(c) : ""; }

  const std::vector<ParamField<Config>>& fields() const { return fields_; }
  const ParamField<Config>* find(const std::string& name) const {
    for (const auto& f : fields_)
      if (f.info.name == name) return &f;
    return nullptr;
  }
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& f : fields_)
      n.push_back(f.info.name);
    return n;
  }
  /// The fields' descriptions, defaults read from a default-constructed Config.
  std::vector<ParamInfo> infos() const {
    const Config defaults{};
    std::vector<ParamInfo> out;
    for (const auto& f : fields_) {
      out.push_back(f.info);
      out.back().default_value = f.get(defaults);
    }
    return out;
  }

 private:
  ParamField<Config>& push(ParamField<Config> f) {
    f.info.section = section_;
    fields_.push_back(std::move(f));
    return fields_.back();
  }

  std::vector<ParamField<Config>> fields_;
  std::string section_;
  Validator validator_;
};

/// Names of the fields whose values differ between `a` and `b`, ORed levels in `levels`.
template <typename Config>
std::vector<std::string> changedFields(const ParamFieldList<Config>& list, const Config& a,
                                       const Config& b, uint32_t* levels = nullptr) {
  std::vector<std::string> changed;
  if (levels != nullptr) *levels = 0;
  for (const auto& f : list.fields()) {
    if (f.get(a) == f.get(b)) continue;
    changed.push_back(f.info.name);
    if (levels != nullptr) *levels |= f.info.level;
  }
  return changed;
}

}  // namespace stereo_safety_map
