// Each subcommand registers itself on the CLI11 app and runs from a callback. Commands throw on
// failure; main() turns any exception into one line on stderr and a non-zero exit.
#pragma once

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

// Thrown for a usage problem the user can fix (exit code 2, like CLI11's own errors).
struct UsageError {
  const char* what;
};

}  // namespace blobvk::app
