// `lane`: the command-line front end of the detector.
#include <cstdio>
#include <string>
#include <vector>

#include "args.h"
#include "commands.h"

namespace {

constexpr char kUsage[] =
    "usage: lane COMMAND [options]\n"
    "\n"
    "Real-time lane marker detection (after Aly, IV 2008).\n"
    "\n"
    "commands:\n"
    "  detect   detect lanes in images, directories, list files or videos\n"
    "  render   render synthetic road frames with ground-truth labels\n"
    "  config   print the effective configuration (every key)\n"
    "  eval     score detections against a labelled data set (paper rule, CULane F1)\n"
    "\n"
    "Run 'lane COMMAND --help' for the options of a command.\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace lane_tools;
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return kExitUsage;
  }
  const std::string command = argv[1];
  const std::vector<std::string> args(argv + 2, argv + argc);
  if (command == "-h" || command == "--help" || command == "help") {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  if (command == "detect") return RunDetect(args);
  if (command == "render") return RunRender(args);
  if (command == "config") return RunConfig(args);
  if (command == "eval") return RunEval(args);
  std::fprintf(stderr, "lane: unknown command \"%s\"\n\n%s", command.c_str(), kUsage);
  return kExitUsage;
}
