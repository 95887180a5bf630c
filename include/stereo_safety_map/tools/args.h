// The offline tools' command line: a walk over argv that reads an option's value into its member
// (a string, a list, a number as std::atoi / atol / atoll / atof / strtoul read it), the command
// line as the reports print it, and the "error: ..." line. What a tool accepts, its checks, its
// usage text and its messages stay in the tool.
#pragma once

#include <string>
#include <vector>

namespace stereo_safety_map {
namespace tools {

class Args {
 public:
  Args(int argc, char** argv) : argc_(argc), argv_(argv) {}
  /// Moves to the next argument; false after the last.
  bool next();
  /// The current argument.
  const std::string& arg() const { return arg_; }
  /// The current argument is `name`: *out = value.
  bool flag(const char* name, bool* out, bool value = true);
  /// The current argument is `name` and a value follows: the value (consumed) read into *out; a
  /// list gets it appended. `name` as the last argument: false, and missingValue() is true.
  bool value(const char* name, std::string* out);
  bool value(const char* name, std::vector<std::string>* out);
  bool value(const char* name, int* out);        ///< std::atoi
  bool value(const char* name, long* out);       ///< std::atol
  bool value(const char* name, long long* out);  ///< std::atoll
  bool value(const char* name, unsigned* out);   ///< std::strtoul
  bool value(const char* name, double* out);     ///< std::atof
  /// The current argument is an option whose value is missing.
  bool missingValue() const { return missing_; }

 private:
  const char* take(const char* name);
  int argc_;
  char** argv_;
  int i_ = 0;
  std::string arg_;
  bool missing_ = false;
};

/// `first`, then argv[1..] separated by spaces: the command line metrics.json and the reports
/// print.
std::string commandLine(const std::string& first, int argc, char** argv);

/// A bad command line: the tool's usage printed, and the exit code for it (2).
int usageError(void (*usage)());

/// Prints "error: <e>" to stderr when `e` is not empty; true when it printed.
bool printError(const std::string& e);

}  // namespace tools
}  // namespace stereo_safety_map
