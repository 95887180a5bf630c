// The README's Parameters lists, generated from the field lists (ros/nodelet_params.h).
//
//   param_table                      print every nodelet's block
//   param_table --nodelet safety_map print one
//   param_table --readme README.md   replace the blocks between the README's markers in place
//
// test_nodelet_params fails while the README's blocks differ from what this prints.
#include "stereo_safety_map/ros/nodelet_params.h"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

namespace ssm = stereo_safety_map;

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: param_table [--nodelet NAME | --readme README.md]\n"
               "  nodelets:");
  for (const ssm::NodeletParams& n : ssm::allNodeletParams())
    std::fprintf(stderr, " %s", n.name.c_str());
  std::fprintf(stderr, "\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 1) {
    for (const ssm::NodeletParams& n : ssm::allNodeletParams())
      std::cout << ssm::readmeParameterBlock(n) << "\n\n";
    return 0;
  }
  if (argc != 3) {
    usage();
    return 2;
  }
  const std::string option = argv[1];
  const std::string value = argv[2];
  if (option == "--nodelet") {
    try {
      std::cout << ssm::readmeParameterBlock(ssm::nodeletParams(value)) << "\n";
    } catch (const std::out_of_range&) {
      usage();
      return 2;
    }
    return 0;
  }
  if (option != "--readme") {
    usage();
    return 2;
  }
  std::ifstream in(value);
  if (!in) {
    std::fprintf(stderr, "error: cannot read %s\n", value.c_str());
    return 1;
  }
  std::stringstream text;
  text << in.rdbuf();
  in.close();
  std::string error;
  const std::string updated = ssm::updateReadmeParameterBlocks(text.str(), &error);
  if (!error.empty()) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  if (updated == text.str()) {
    std::printf("%s is up to date\n", value.c_str());
    return 0;
  }
  std::ofstream out(value);
  out << updated;
  if (!out) {
    std::fprintf(stderr, "error: cannot write %s\n", value.c_str());
    return 1;
  }
  std::printf("updated the parameter lists in %s\n", value.c_str());
  return 0;
}
