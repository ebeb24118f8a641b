// `blobvk convert IN OUT.json`: legacy .blob/.scene (or JSON) to the JSON scene format.
#include "commands.h"

#include "blobtree/scene_io.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>

namespace blobvk::app {

void addConvertCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("convert", "Convert a scene (.blob, .scene, .json) to JSON");
  auto in = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  cmd->add_option("input", *in, "Input scene")->required();
  cmd->add_option("output", *out, "Output .json")->required();
  cmd->callback([in, out] {
    const blobtree::Scene scene = blobtree::loadScene(*in);
    blobtree::saveSceneJson(scene, *out);
    const blobtree::TreeStats s = blobtree::treeStats(scene.root);
    std::printf("wrote %s (%zu nodes)\n", out->c_str(), s.primitives + s.operators + s.warps);
  });
}

}  // namespace blobvk::app
