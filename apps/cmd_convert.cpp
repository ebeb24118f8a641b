// `blobvk convert IN OUT.json`: legacy .blob/.scene (or JSON) to the JSON scene format; OUT "-"
// prints the JSON on standard output. blobvk writes JSON only: any other output extension (a
// .blob included) is refused before reading the input.
#include "cli_conventions.h"
#include "commands.h"
#include "progress.h"

#include "blobvk/blobtree/scene_io.h"
#include "blobvk/blobtree/scene_json.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>

namespace blobvk::app {

void addConvertCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("convert", "Convert a scene (.blob, .scene, .json) to JSON");
  auto in = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  cmd->add_option("input", *in, "Input scene")->required();
  cmd->add_option("output", *out, "Output .json (- for standard output)")->required();
  cmd->callback([in, out] {
    const bool toStdout = checkOutputFile(*out, {".json"}, true, "a scene (blobvk writes the JSON format only)");
    const blobtree::Scene scene = blobtree::loadScene(*in);
    writeOutput(*out, blobtree::writeSceneJson(scene));
    const blobtree::TreeStats s = blobtree::treeStats(scene.root);
    const std::string summary = "wrote " + (toStdout ? std::string("standard output") : *out) + " (" + std::to_string(s.primitives + s.operators + s.warps) + " nodes)";
    // With the JSON on standard output the summary goes to stderr, like progress.
    if (toStdout) Progress::note("convert", summary);
    else std::printf("%s\n", summary.c_str());
  });
}

}  // namespace blobvk::app
