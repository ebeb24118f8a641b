// blobvk: implicit models to meshes and images. See README.md and `blobvk --help`.
// Exit status: 0 success, 1 error, 2 usage error, 3 a failed `compare` (cli_conventions.h).
#include "backends.h"
#include "cli_conventions.h"
#include "commands.h"
#include "render_command.h"

#include <CLI/CLI.hpp>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>

int main(int argc, char** argv) {
  // lavapipe tuning, set by the process (the library never touches the environment) and only
  // where the user has not chosen: llvmpipe picks 512-bit vectors on AVX-512 CPUs, and 256-bit
  // ones measured faster for every kernel (docs/vulkan.md). Other drivers ignore it.
  setenv("LP_NATIVE_VECTOR_WIDTH", "256", 0);
  using namespace blobvk::app;
  CLI::App app{"blobvk: BlobTree implicit models to meshes, images and soft bodies"};
  app.require_subcommand(1);
  app.set_version_flag("--version", versionString());
  // Global flags may also follow the subcommand (`blobvk mesh ... -q`): subcommands created
  // below inherit fallthrough and hand options they do not know to this parent.
  app.fallthrough();
  bool quietFlag = false;
  app.add_flag("-q,--quiet", quietFlag, "No progress or informational lines on stderr (mesh, render: no summary)");
  app.parse_complete_callback([&quietFlag] { setQuiet(quietFlag); });
  // Where the Vulkan pipeline cache lives (vk/device/standalone.h): passed to the library through the
  // variable it reads, so every command that creates a device honours it.
  app.add_option_function<std::string>(
         "--pipeline-cache", [](const std::string& dir) { setenv("BLOBVK_PIPELINE_CACHE", dir.c_str(), 1); },
         "Vulkan pipeline cache directory, or 'off' (default: $BLOBVK_PIPELINE_CACHE, else "
         "$XDG_CACHE_HOME/blobvk or ~/.cache/blobvk)")
      ->type_name("DIR|off")
      ->trigger_on_parse();
  // Usage errors are one line and exit 2 whatever CLI11's own code for them.
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    std::string command;  // "generate tower " for a nested subcommand, "" for the tool itself
    for (const CLI::App* a = failed; a && a->get_parent(); a = a->get_parent()) command = a->get_name() + " " + command;
    return "blobvk: usage error: " + printable(e.what()) + " (see blobvk " + command + "--help)\n";
  });
  addGenerateCommand(app);
  addMeshCommand(app);
  addInfoCommand(app);
  addConvertCommand(app);
  addBenchCommand(app);
  addSimulateCommand(app);
  addCutCommand(app);
  addEditCommand(app);
  addDevicesCommand(app);
  addCompareCommand(app);
  addRenderCommand(app);
  // The shared Vulkan devices go before main returns, on every path (apps/backends.cpp says why).
  struct ReleaseDevices {
    ~ReleaseDevices() { releaseSharedDevices(); }
  } releaseDevices;
  try {
    app.parse(argc, argv);
    // Reports printed on stdout (summaries, --json) are the command's output too: a full disk
    // or closed pipe must not end in exit status 0 with an empty file.
    errno = 0;
    if (std::fflush(stdout) != 0 || std::ferror(stdout))
      throw std::runtime_error("standard output: write error: " + systemReason(errno ? errno : EIO));
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "blobvk: usage error: %s\n", printable(e.what()).c_str());
    return kExitUsage;
  } catch (const ComparisonFailed& e) {
    std::fprintf(stderr, "blobvk: comparison failed: %s\n", printable(e.message).c_str());
    return kExitComparisonFailed;
  } catch (const std::exception& e) {
    // One clear line; the library's messages already name the file and the place.
    std::fprintf(stderr, "blobvk: error: %s\n", printable(e.what()).c_str());
    return kExitError;
  }
  return 0;
}
