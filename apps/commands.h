// Each subcommand registers itself on the CLI11 app and runs from a callback. Commands throw on
// failure; main() turns any exception into one line on stderr and a non-zero exit.
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace blobvk::app {

void addGenerateCommand(CLI::App& app);
void addMeshCommand(CLI::App& app);
void addInfoCommand(CLI::App& app);
void addConvertCommand(CLI::App& app);
void addBenchCommand(CLI::App& app);
void addDevicesCommand(CLI::App& app);
void addCompareCommand(CLI::App& app);
void addSimulateCommand(CLI::App& app);
void addCutCommand(CLI::App& app);
void addEditCommand(CLI::App& app);

// A comparison that ran but did not meet its thresholds: exit code 3 (errors give 1).
struct ComparisonFailed {
  std::string message;
};

}  // namespace blobvk::app
