// `blobvk info SCENE [--json]`: what the tree holds and what it compiles to.
#include "commands.h"
#include "json_report.h"
#include "model.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>

namespace blobvk::app {

void addInfoCommand(CLI::App& app) {
  struct Args {
    std::string path;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("info", "Node counts, depth and the compiled Program of a scene");
  cmd->add_option("scene", a->path, "Scene file (.json, .blob, .scene)")->required();
  cmd->add_flag("--json", a->json, "Print the facts as JSON (with the blobvk version)");
  cmd->callback([a] {
    const Model m = loadModel(a->path);
    const blobtree::TreeStats s = blobtree::treeStats(m.scene.root);
    const blobtree::Program& p = m.program;
    std::optional<blobtree::GridSpec> grid;
    if (p.bounds.finite()) grid = gridFor(m, std::nullopt, std::nullopt);
    if (a->json) {
      nlohmann::json out = versionJson();
      out["scene"] = a->path;
      out["name"] = m.scene.name;
      out["nodes"] = {{"total", s.primitives + s.operators + s.warps}, {"primitives", s.primitives},
                      {"operators", s.operators}, {"warps", s.warps}, {"depth", s.depth}};
      out["program"] = {{"instructions", p.code.size()}, {"field_registers", p.fieldRegisters},
                        {"point_registers", p.pointRegisters}, {"primitives", p.primitives.size()},
                        {"matrices", p.matrices.size()}, {"boxes", p.boxes.size()}, {"warps", p.warps.size()},
                        {"bytes", p.byteSize()}};
      if (grid) {
        out["bounds"] = {{"lo", {p.bounds.lo.x, p.bounds.lo.y, p.bounds.lo.z}}, {"hi", {p.bounds.hi.x, p.bounds.hi.y, p.bounds.hi.z}}};
        out["default_grid"] = {{"cells", {grid->cells.x, grid->cells.y, grid->cells.z}}, {"cell_size", grid->cellSize}};
      } else {
        out["bounds"] = p.bounds.empty() ? "empty" : "unbounded";
      }
      std::printf("%s\n", out.dump(2).c_str());
      return;
    }
    std::printf("scene        %s%s%s\n", a->path.c_str(), m.scene.name.empty() ? "" : "  name: ", m.scene.name.c_str());
    std::printf("nodes        %zu (%zu primitives, %zu operators, %zu warps), depth %zu\n",
                s.primitives + s.operators + s.warps, s.primitives, s.operators, s.warps, s.depth);
    std::printf("program      %zu instructions, %u field registers, %u point registers\n", p.code.size(),
                p.fieldRegisters, p.pointRegisters);
    std::printf("records      %zu primitives, %zu matrices, %zu boxes, %zu warps: %zu bytes\n", p.primitives.size(),
                p.matrices.size(), p.boxes.size(), p.warps.size(), p.byteSize());
    if (grid) {
      std::printf("bounds       (%.4g, %.4g, %.4g) .. (%.4g, %.4g, %.4g)\n", p.bounds.lo.x, p.bounds.lo.y, p.bounds.lo.z,
                  p.bounds.hi.x, p.bounds.hi.y, p.bounds.hi.z);
      std::printf("default grid %d x %d x %d cells of %.4g\n", grid->cells.x, grid->cells.y, grid->cells.z, grid->cellSize);
    } else {
      std::printf("bounds       %s\n", p.bounds.empty() ? "empty" : "unbounded");
    }
  });
}

}  // namespace blobvk::app
