// blobvk: implicit models to meshes and images. See README.md and `blobvk --help`.
#include "commands.h"
#include "render_command.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <exception>

int main(int argc, char** argv) {
  // lavapipe tuning, set by the process (the library never touches the environment) and only
  // where the user has not chosen: llvmpipe picks 512-bit vectors on AVX-512 CPUs, and 256-bit
  // ones measured faster for every kernel (docs/vulkan.md). Other drivers ignore it.
  setenv("LP_NATIVE_VECTOR_WIDTH", "256", 0);
  CLI::App app{"blobvk: BlobTree implicit models to meshes, images and soft bodies"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "blobvk 0.1.0");
  blobvk::app::addGenerateCommand(app);
  blobvk::app::addMeshCommand(app);
  blobvk::app::addInfoCommand(app);
  blobvk::app::addConvertCommand(app);
  blobvk::app::addBenchCommand(app);
  blobvk::app::addSimulateCommand(app);
  blobvk::app::addCutCommand(app);
  blobvk::app::addDevicesCommand(app);
  blobvk::app::addCompareCommand(app);
  blobvk::app::addRenderCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const blobvk::app::ComparisonFailed& e) {
    std::fprintf(stderr, "blobvk: comparison failed: %s\n", e.message.c_str());
    return 3;
  } catch (const std::exception& e) {
    // One clear line; the library's messages already name the file and the place.
    std::fprintf(stderr, "blobvk: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
