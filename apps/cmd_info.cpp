// `blobvk info SCENE`: what the tree holds and what it compiles to.
#include "commands.h"
#include "model.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>

namespace blobvk::app {

void addInfoCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("info", "Node counts, depth and the compiled Program of a scene");
  auto path = std::make_shared<std::string>();
  cmd->add_option("scene", *path, "Scene file (.json, .blob, .scene)")->required();
  cmd->callback([path] {
    const Model m = loadModel(*path);
    const blobtree::TreeStats s = blobtree::treeStats(m.scene.root);
    const blobtree::Program& p = m.program;
    std::printf("scene        %s%s%s\n", path->c_str(), m.scene.name.empty() ? "" : "  name: ",
                m.scene.name.c_str());
    std::printf("nodes        %zu (%zu primitives, %zu operators, %zu warps), depth %zu\n",
                s.primitives + s.operators + s.warps, s.primitives, s.operators, s.warps, s.depth);
    std::printf("program      %zu instructions, %u field registers, %u point registers\n",
                p.code.size(), p.fieldRegisters, p.pointRegisters);
    std::printf("records      %zu primitives, %zu matrices, %zu boxes, %zu warps: %zu bytes\n",
                p.primitives.size(), p.matrices.size(), p.boxes.size(), p.warps.size(),
                p.byteSize());
    if (p.bounds.finite()) {
      std::printf("bounds       (%.4g, %.4g, %.4g) .. (%.4g, %.4g, %.4g)\n", p.bounds.lo.x,
                  p.bounds.lo.y, p.bounds.lo.z, p.bounds.hi.x, p.bounds.hi.y, p.bounds.hi.z);
      const blobtree::GridSpec g = gridFor(m, std::nullopt, std::nullopt);
      std::printf("default grid %d x %d x %d cells of %.4g\n", g.cells.x, g.cells.y, g.cells.z,
                  g.cellSize);
    } else {
      std::printf("bounds       %s\n", p.bounds.empty() ? "empty" : "unbounded");
    }
  });
}

}  // namespace blobvk::app
