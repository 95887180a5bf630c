// The command-line tools' one JSON writer (metrics.json of the evaluators, bench_pipeline's
// --json): objects, arrays, numbers (%.6g; NaN / inf as null), integers, booleans, strings, null.
// Compact (one line) by default; `Json(true)` puts every member on its own line, indented by two
// spaces a level (bench.json); `wrap(n)` starts the next member, element or closing bracket on a
// new line indented by n spaces (the hand-made layouts of evaluate_hybrid's and
// evaluate_occupancy_2d's metrics.json). Header-only.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <string>

namespace stereo_safety_map {
namespace tools {

class Json {
 public:
  explicit Json(bool pretty = false) : pretty_(pretty) {}
  std::string str() const { return os_.str(); }
  Json& open(char c) {
    sep();
    os_ << c;
    first_ = true;
    ++depth_;
    return *this;
  }
  Json& close(char c) {
    --depth_;
    if (wrap_ >= 0) {
      wrapLine();
    } else if (pretty_) {
      newline();
    }
    os_ << c;
    first_ = false;
    return *this;
  }
  Json& key(const std::string& k) {
    sep();
    quote(k);
    os_ << ": ";
    first_ = true;
    after_key_ = true;
    return *this;
  }
  Json& val(double v) {
    sep();
    if (std::isfinite(v)) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.6g", v);
      os_ << buf;
    } else {
      os_ << "null";
    }
    return *this;
  }
  Json& val(long long v) {
    sep();
    os_ << v;
    return *this;
  }
  Json& val(long v) { return val(static_cast<long long>(v)); }
  Json& val(int v) { return val(static_cast<long long>(v)); }
  Json& val(std::uint64_t v) { return val(static_cast<long long>(v)); }
  Json& val(bool v) {
    sep();
    os_ << (v ? "true" : "false");
    return *this;
  }
  Json& val(const std::string& s) {
    sep();
    quote(s);
    return *this;
  }
  Json& val(const char* s) { return val(std::string(s)); }
  /// A value written as it is: a number as a paper prints it ("0.90"), already formatted.
  Json& raw(const std::string& text) {
    sep();
    os_ << text;
    return *this;
  }
  Json& null() {
    sep();
    os_ << "null";
    return *this;
  }
  template <typename T>
  Json& kv(const std::string& k, const T& v) {
    key(k);
    return val(v);
  }
  /// The next member, element or closing bracket on a new line, indented by `spaces` (the comma
  /// before it stays at the end of the line).
  Json& wrap(int spaces) {
    wrap_ = spaces;
    return *this;
  }
  /// `k`: v written as a number (%.6g) whatever its type, counts included (evaluate_obstacles'
  /// metrics.json has always written its counts so).
  Json& num(const std::string& k, double v) {
    key(k);
    return val(v);
  }

 private:
  void sep() {
    if (after_key_) {
      after_key_ = false;
      first_ = false;
      return;
    }
    if (!first_) os_ << (pretty_ || wrap_ >= 0 ? "," : ", ");
    if (wrap_ >= 0) {
      wrapLine();
    } else if (pretty_ && depth_ > 0) {
      newline();
    }
    first_ = false;
  }
  void wrapLine() {
    os_ << '\n' << std::string(static_cast<std::size_t>(wrap_), ' ');
    wrap_ = -1;
  }
  void newline() { os_ << '\n' << std::string(2 * static_cast<std::size_t>(depth_), ' '); }
  void quote(const std::string& s) {
    os_ << '"';
    for (char c : s) {
      if (c == '"' || c == '\\') {
        os_ << '\\' << c;
      } else if (static_cast<unsigned char>(c) < 0x20) {
        char buf[8];
        std::snprintf(buf, sizeof(buf), "\\u%04x", c);
        os_ << buf;
      } else {
        os_ << c;
      }
    }
    os_ << '"';
  }
  std::ostringstream os_;
  bool pretty_ = false;
  int depth_ = 0;
  bool first_ = true;
  bool after_key_ = false;
  int wrap_ = -1;
};

}  // namespace tools
}  // namespace stereo_safety_map
