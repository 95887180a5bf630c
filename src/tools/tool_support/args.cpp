#include "stereo_safety_map/tools/args.h"

#include <cstdio>
#include <cstdlib>

namespace stereo_safety_map {
namespace tools {

bool Args::next() {
  if (++i_ >= argc_) return false;
  arg_ = argv_[i_];
  missing_ = false;
  return true;
}

const char* Args::take(const char* name) {
  if (arg_ != name) return nullptr;
  if (i_ + 1 >= argc_) {
    missing_ = true;
    return nullptr;
  }
  return argv_[++i_];
}

bool Args::flag(const char* name, bool* out, bool value) {
  if (arg_ != name) return false;
  *out = value;
  return true;
}

bool Args::value(const char* name, std::string* out) {
  const char* v = take(name);
  if (v != nullptr) *out = v;
  return v != nullptr;
}

bool Args::value(const char* name, std::vector<std::string>* out) {
  const char* v = take(name);
  if (v != nullptr) out->push_back(v);
  return v != nullptr;
}

bool Args::value(const char* name, int* out) {
  const char* v = take(name);
  if (v != nullptr) *out = std::atoi(v);
  return v != nullptr;
}

bool Args::value(const char* name, long* out) {
  const char* v = take(name);
  if (v != nullptr) *out = std::atol(v);
  return v != nullptr;
}

bool Args::value(const char* name, long long* out) {
  const char* v = take(name);
  if (v != nullptr) *out = std::atoll(v);
  return v != nullptr;
}

bool Args::value(const char* name, unsigned* out) {
  const char* v = take(name);
  if (v != nullptr) *out = static_cast<unsigned>(std::strtoul(v, nullptr, 10));
  return v != nullptr;
}

bool Args::value(const char* name, double* out) {
  const char* v = take(name);
  if (v != nullptr) *out = std::atof(v);
  return v != nullptr;
}

std::string commandLine(const std::string& first, int argc, char** argv) {
  std::string c = first;
  for (int i = 1; i < argc; ++i)
    c += std::string(" ") + argv[i];
  return c;
}

int usageError(void (*usage)()) {
  usage();
  return 2;
}

bool printError(const std::string& e) {
  if (e.empty()) return false;
  std::fprintf(stderr, "error: %s\n", e.c_str());
  return true;
}

}  // namespace tools
}  // namespace stereo_safety_map
