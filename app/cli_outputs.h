// An output never replaces what the command reads: `export S --format
// rosbag --out S/frames.bin` replaced the recording with a bag, `simulate
// --truth` named as its --scenario overwrote the scenario, and `plan
// d.ply --svg d.ply` the cloud. Refused with exit 2 before any work.
#ifndef SWEEPSCAN_APP_CLI_OUTPUTS_H_
#define SWEEPSCAN_APP_CLI_OUTPUTS_H_

#include <string>
#include <vector>

namespace sweepscan::app {

// One output of a command: its option ("--out") and path.
struct CommandOutput {
  std::string option;
  std::string path;
};
// One input: how the message names it ("the --pairs file", "the session
// folder lab.sweepscan, which holds the recording") and its path. A folder
// holds no output (whether it exists yet or not); a file is no output.
struct CommandInput {
  std::string what;
  std::string path;
  bool folder = false;
};

// "" when no output replaces an input or another output (two outputs
// named alike would write one file twice); else the one line saying which,
// e.g. "--svg d.ply is the cloud d.ply: it would be replaced". Outputs
// with an empty path are not given.
std::string OutputOverInput(const std::vector<CommandOutput>& outputs,
                            const std::vector<CommandInput>& inputs);
// The same as a command's exit: the line printed and kExitBadInput, or
// kExitOk.
int RefuseOutputOverInput(const std::vector<CommandOutput>& outputs,
                          const std::vector<CommandInput>& inputs);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_CLI_OUTPUTS_H_
