// Typed, validating reads from the parameter server (after voxblox's ros_params.h: validate as
// you read). The same rules as params.cpp / disparity_params.cpp: an absent parameter keeps its
// value, a parameter of the wrong type (an integer given as 0.5, a string for a number) is
// refused with a message naming it, never truncated; the first error wins.
//
// Header-only so that a nodelet's parameter file can use it without another library target.
#pragma once

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <limits>
#include <sstream>
#include <string>

namespace stereo_safety_map {

class ParamReader {
 public:
  explicit ParamReader(const ros::NodeHandle& pnh) : pnh_(pnh) {}

  void read(const std::string& name, double* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
      *value = static_cast<double>(v);
    } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
      *value = static_cast<int>(v);
    } else if (v.getType() == XmlRpc::XmlRpcValue::TypeString &&
               (static_cast<std::string>(v) == "inf" || static_cast<std::string>(v) == ".inf")) {
      // `rosparam set x inf` stores a string; the range checks decide whether inf is allowed.
      *value = std::numeric_limits<double>::infinity();
    } else {
      fail(name, v, "a number");
    }
  }
  void read(const std::string& name, int* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
      *value = static_cast<int>(v);
    } else {
      fail(name, v, "an integer");
    }
  }
  void read(const std::string& name, bool* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeBoolean) {
      *value = static_cast<bool>(v);
    } else {
      fail(name, v, "true or false");
    }
  }
  void read(const std::string& name, std::string* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeString) {
      *value = static_cast<std::string>(v);
    } else {
      fail(name, v, "a string");
    }
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
  void fail(const std::string& name, XmlRpc::XmlRpcValue& v, const char* expected) {
    std::ostringstream os;
    os << "invalid parameter " << pnh_.resolveName(name) << ": must be " << expected << ", got ";
    v.write(os);
    error_ = os.str();
  }

  const ros::NodeHandle& pnh_;
  std::string error_;
};

}  // namespace stereo_safety_map
