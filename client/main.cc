// lane-client: the bundled client of lane-server. See docs/client.md.
//
//   lane-client session create --camera cam0 --config configs/synthetic.json
//   lane-client stream --camera cam0 --output results.jsonl frames/
//   lane-client bench --cameras 4 --duration 10s --inprocess
//   lane-client health
#include <string>
#include <vector>

#include "commands.h"

int main(int argc, char** argv) {
  return lane::client::RunCommand(std::vector<std::string>(argv + 1, argv + argc));
}
