// `blobvk generate tower|eggshell|random -o scene.json`: the thesis' procedural test models.
#include "cli_conventions.h"
#include "number_checks.h"
#include "commands.h"
#include "progress.h"

#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/blobtree/scene_limits.h"

#include <CLI/CLI.hpp>

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <memory>

namespace blobvk::app {
namespace {

// Writes the scene once the readers accept it: options in range can still place a node where no
// scene may (a tower of 101 levels of height 10^4 reaches past the coordinate limit of 10^6), and
// a generated file that no command opens is a failure, not an output. `options` names the
// settings to change.
void save(blobtree::Node root, const std::string& name, const std::string& out, const std::string& options) {
  blobtree::Scene scene;
  scene.root = std::move(root);
  scene.name = name;
  const std::string text = blobtree::writeSceneJson(scene);
  if (text.size() > blobtree::limits::kMaxSceneBytes)  // the readers' file limit (parseSceneJson takes text)
    throw CLI::ValidationError(options, "the scene would take " + std::to_string(text.size() >> 20) +
                                            " MiB, more than the 256 MiB a scene file may: change " + options);
  try {
    (void)blobtree::parseSceneJson(text, name);
  } catch (const std::exception& e) {
    throw CLI::ValidationError(options, std::string("the scene would not load (") + e.what() + "): change " + options);
  }
  writeOutput(out, text);
  const blobtree::TreeStats s = blobtree::treeStats(scene.root);
  char summary[256];
  std::snprintf(summary, sizeof summary, "wrote %s: %zu primitives, %zu operators, depth %zu", out == "-" ? "standard output" : out.c_str(), s.primitives,
                s.operators, s.depth);
  if (out == "-") Progress::note("generate", summary);  // stdout holds the scene
  else std::printf("%s\n", summary);
}

// "-o -" streams the scene; a file must be .json, in a writable folder (checked first).
void checkOutput(const std::string& out) { checkOutputFile(out, {".json"}, true, "a scene"); }

std::size_t nodeCount(const blobtree::Node& root) {
  const blobtree::TreeStats s = blobtree::treeStats(root);
  return s.primitives + s.operators + s.warps;
}

// A tower's node count from one level's, before building it: a scene over the readers' limit
// would take minutes and gigabytes to write and then not load.
void checkTowerSize(int levels, int pillars, double radius, double height, int grid) {
  const std::size_t level = nodeCount(blobtree::generateTower(1, pillars, radius, height, 1)) - 1;  // less its union
  const std::size_t tower = std::size_t(levels) * level + 1;
  const std::size_t nodes = std::size_t(grid) * std::size_t(grid) * tower + (grid > 1 ? 1 : 0);
  if (nodes > blobtree::limits::kMaxNodes)
    throw CLI::ValidationError("--levels/--pillars/--grid", "the tower would have " + std::to_string(nodes) +
                               " nodes, more than the " + std::to_string(blobtree::limits::kMaxNodes) +
                               " a scene may hold (docs/scene-format.md): fewer levels, pillars or towers");
}

}  // namespace

void addGenerateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("generate", "Write a procedural test model as a JSON scene");
  cmd->require_subcommand(1);

  struct Tower {
    int levels = 4, pillars = 8, grid = 1;
    double radius = 6.0, height = 6.0;
    std::string out;
  };
  auto tower = std::make_shared<Tower>();
  auto* t = cmd->add_subcommand("tower", "The thesis' 'Piza' tower, instanced on a grid");
  t->add_option("--levels", tower->levels, "Stacked levels")->check(CLI::Range(1, 1000));
  t->add_option("--pillars", tower->pillars, "Pillars per level")->check(CLI::Range(1, 1000));
  t->add_option("--radius", tower->radius, "Radius of the pillar circle")->check(finiteRange(0.01, 1e4));
  t->add_option("--height", tower->height, "Pillar height")->check(finiteRange(0.01, 1e4));
  t->add_option("--grid", tower->grid, "Towers per side of the I x I grid")->check(CLI::Range(1, 100));
  t->add_option("-o,--output", tower->out, "Output .json (- for standard output)")->required();
  t->callback([tower] {
    checkOutput(tower->out);
    checkTowerSize(tower->levels, tower->pillars, tower->radius, tower->height, tower->grid);
    save(blobtree::generateTower(tower->levels, tower->pillars, tower->radius, tower->height,
                                 tower->grid),
         "tower", tower->out, "--levels/--pillars/--radius/--height/--grid");
  });

  auto eggOut = std::make_shared<std::string>();
  auto* e = cmd->add_subcommand("eggshell", "Difference of two scaled points (the FEM test model)");
  e->add_option("-o,--output", *eggOut, "Output .json (- for standard output)")->required();
  e->callback([eggOut] {
    checkOutput(*eggOut);
    save(blobtree::generateEggshell(), "eggshell", *eggOut, "the eggshell");
  });

  struct Random {
    int count = 128;
    std::uint64_t seed = 1;
    double ricci = 0.0;  // 0: a plain blend
    std::string out;
  };
  auto random = std::make_shared<Random>();
  auto* r = cmd->add_subcommand("random", "Blend of N random points (deterministic per seed)");
  r->add_option("--count", random->count, "Number of points")->check(CLI::Range(1, 1000000));
  // CLI11 would read -1 into the unsigned seed as 2^64 - 1.
  r->add_option("--seed", random->seed, "Random seed (0 to 2^64 - 1)")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            std::uint64_t v = 0;
            const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
            return !text.empty() && ec == std::errc() && end == text.data() + text.size()
                       ? std::string()
                       : "'" + text + "' is not a whole number from 0 to 2^64 - 1";
          },
          "UINT64"));
  r->add_option("--ricci", random->ricci,
                 "Join the points with a Ricci blend of this power, (sum f^n)^(1/n), instead of a blend (sum f)")
      ->check(finiteRange(0.01, 1000.0));
  r->add_option("-o,--output", random->out, "Output .json (- for standard output)")->required();
  r->callback([random] {
    checkOutput(random->out);
    save(random->ricci > 0.0 ? blobtree::generateRandomRicciBlobs(random->count, random->seed, random->ricci)
                             : blobtree::generateRandomBlobs(random->count, random->seed),
         "random", random->out, "--count/--seed/--ricci");
  });
}

}  // namespace blobvk::app
