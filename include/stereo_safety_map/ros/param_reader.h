// Typed, validating reads from the parameter server (after voxblox's ros_params.h: validate as
// you read). The same rules as params.cpp / disparity_params.cpp: an absent parameter keeps its
// value, a parameter of the wrong type (an integer given as 0.5, a string for a number) is
// refused with a message naming it, never truncated; the first error wins.
//
// readFields() / readParams() read a whole field list (core/param_fields.h): every field is read
// with its type, stored through its accessor, and the list's validation ends the read.
//
// Header-only so that a nodelet's parameter file can use it without another library target.
#pragma once

#include "stereo_safety_map/core/param_fields.h"

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace stereo_safety_map {

class ParamReader {
 public:
  explicit ParamReader(const ros::NodeHandle& pnh) : pnh_(pnh) {}

  /// Each read returns true when it stored a value: the parameter is set, has the right type and
  /// no error came before.
  bool read(const std::string& name, double* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return false;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
      *value = static_cast<double>(v);
    } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
      *value = static_cast<int>(v);
    } else if (v.getType() == XmlRpc::XmlRpcValue::TypeString &&
               (static_cast<std::string>(v) == "inf" || static_cast<std::string>(v) == ".inf")) {
      // `rosparam set x inf` stores a string; the range checks decide whether inf is allowed.
      *value = std::numeric_limits<double>::infinity();
    } else {
      return fail(name, v, "a number");
    }
    return true;
  }
  bool read(const std::string& name, int* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return false;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeInt) return fail(name, v, "an integer");
    *value = static_cast<int>(v);
    return true;
  }
  bool read(const std::string& name, bool* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return false;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) return fail(name, v, "true or false");
    *value = static_cast<bool>(v);
    return true;
  }
  bool read(const std::string& name, std::string* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return false;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeString) return fail(name, v, "a string");
    *value = static_cast<std::string>(v);
    return true;
  }

  /// One field of a field list: read with the field's type and stored through its accessor; a
  /// value the accessor refuses (an unknown enum name) is an error naming it. External fields
  /// (read by a library) are skipped.
  template <typename Config>
  void read(const ParamField<Config>& field, Config* config) {
    if (!field.set || !error_.empty()) return;
    const std::string& name = field.info.name;
    ParamValue value = field.get(*config);
    bool got = false;
    switch (field.info.type) {
      case ParamType::kBool:
        got = read(name, &std::get<bool>(value));
        break;
      case ParamType::kInt:
        got = read(name, &std::get<int>(value));
        break;
      case ParamType::kDouble:
        got = read(name, &std::get<double>(value));
        break;
      case ParamType::kString:
        got = read(name, &std::get<std::string>(value));
        break;
    }
    if (!got) return;
    const std::string why = field.set(config, value);
    if (!why.empty()) error_ = "invalid parameter in " + pnh_.getNamespace() + ": " + why;
  }
  /// Every field of `list`, in its order; absent parameters keep their values.
  template <typename Config>
  void readFields(const ParamFieldList<Config>& list, Config* config) {
    for (const ParamField<Config>& f : list.fields())
      read(f, config);
  }

  /// The first type error (empty while there is none).
  const std::string& error() const { return error_; }
  /// The first type error, or `range_error` (a validate() message) prefixed with the namespace;
  /// empty when both are empty.
  std::string result(const std::string& range_error) const {
    if (!error_.empty()) return error_;
    if (range_error.empty()) return "";
    return "invalid parameter in " + pnh_.getNamespace() + ": " + range_error;
  }

 private:
  bool fetch(const std::string& name, XmlRpc::XmlRpcValue* v) {
    if (!error_.empty() || !pnh_.hasParam(name)) return false;
    return pnh_.getParam(name, *v);
  }
  bool fail(const std::string& name, XmlRpc::XmlRpcValue& v, const char* expected) {
    std::ostringstream os;
    os << "invalid parameter " << pnh_.resolveName(name) << ": must be " << expected << ", got ";
    v.write(os);
    error_ = os.str();
    return false;
  }

  const ros::NodeHandle& pnh_;
  std::string error_;
};

/// Reads the fields of `list` from pnh's namespace into `config` and validates with the list's
/// validator: empty when valid, else the first type error or the range message, naming the
/// parameter (prefixed with the namespace).
template <typename Config>
std::string readParams(const ros::NodeHandle& pnh, const ParamFieldList<Config>& list,
                       Config* config) {
  ParamReader r(pnh);
  r.readFields(list, config);
  if (!r.error().empty()) return r.error();
  return r.result(list.validate(*config));
}

/// Parameters set in pnh's namespace (first level) that are not in `known`: likely typos (every
/// nodelet warns about them once at start).
inline std::vector<std::string> unknownParameters(const ros::NodeHandle& pnh,
                                                  const std::vector<std::string>& known) {
  std::vector<std::string> all;
  std::vector<std::string> unknown;
  if (!pnh.getParamNames(all)) return unknown;
  const std::string prefix = pnh.getNamespace() + "/";
  for (const std::string& name : all) {
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    std::string rest = name.substr(prefix.size());
    rest = rest.substr(0, rest.find('/'));  // first level only
    if (std::find(known.begin(), known.end(), rest) == known.end() &&
        std::find(unknown.begin(), unknown.end(), rest) == unknown.end()) {
      unknown.push_back(rest);
    }
  }
  return unknown;
}

/// "<name> = <value> is out of range <range>": the wording of the hybrid safety map's and the
/// safety gate's validate().
inline std::string rangeError(const char* name, double value, const char* range) {
  std::ostringstream os;
  os << name << " = " << value << " is out of range " << range;
  return os.str();
}

}  // namespace stereo_safety_map
