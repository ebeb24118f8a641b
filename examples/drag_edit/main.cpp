// drag_edit: what an interactive modeller does with blobvk on the CPU. It loads a scene, picks a
// primitive, and drags it around a circle, one small move per frame; each frame applies the move
// as an edit (blobtree::EditableTree) and re-meshes only what the move touched
// (cpu::IncrementalPolygonizer). A real host would draw the mesh; this one prints the frame
// latency and, with --check, compares every frame's mesh with a full re-mesh of the same grid.
//
//   drag_edit SCENE [--node ID | --path 0,3,1] [--frames N] [--radius R] [--resolution N] [--check]
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/incremental_polygonizer.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

using namespace blobvk;

// The first primitive in pre-order: something to drag when the user names nothing.
blobtree::NodePath firstPrimitive(const blobtree::Node& root) {
  blobtree::NodePath path;
  const blobtree::Node* n = &root;
  while (!n->isPrimitive()) {
    path.push_back(0);
    n = &n->children.front();
  }
  return path;
}

blobtree::NodePath parsePath(const std::string& text) {
  blobtree::NodePath path;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t comma = text.find(',', at);
    path.push_back(std::stoul(text.substr(at, comma - at)));
    at = comma == std::string::npos ? text.size() : comma + 1;
  }
  return path;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 2) {
    std::fprintf(stderr, "usage: drag_edit SCENE [--node ID | --path 0,3,1] [--frames N] [--radius R] "
                         "[--resolution N] [--check]\n");
    return 2;
  }
  std::string node, pathText;
  int frames = 24, resolution = 128;
  double radius = -1.0;
  bool check = false;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--node") node = value();
    else if (arg == "--path") pathText = value();
    else if (arg == "--frames") frames = std::stoi(value());
    else if (arg == "--radius") radius = std::stod(value());
    else if (arg == "--resolution") resolution = std::stoi(value());
    else if (arg == "--check") check = true;
    else throw std::invalid_argument("unknown option " + arg);
  }

  const blobtree::Scene scene = blobtree::loadScene(argv[1]);
  blobtree::EditableTree tree(scene.root);
  blobtree::NodePath path = firstPrimitive(tree.root());
  if (!node.empty()) {
    const auto found = tree.find(node);
    if (!found) throw std::invalid_argument("no node with id '" + node + "'");
    path = *found;
  } else if (!pathText.empty()) {
    path = parsePath(pathText);
  }
  const blobtree::Transform home = tree.node(path).transform;

  // The grid stays fixed while editing: the incremental mesh equals the full one on this grid.
  blobtree::GridRequest request;
  request.resolution = resolution;
  const blobtree::GridSpec grid = blobtree::chooseGrid(tree.program(), scene.grid, request);
  if (radius < 0.0) radius = 2.0 * double(grid.cellSize);
  cpu::IncrementalPolygonizer mesher(grid);
  auto t0 = std::chrono::steady_clock::now();
  std::size_t triangles = mesher.reset(tree.program()).triangleCount();
  const double fullMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%s: node %s, %d x %d x %d cells, full mesh %.1f ms, %zu triangles\n", argv[1],
              blobtree::toString(path).c_str(), grid.cells.x, grid.cells.y, grid.cells.z, fullMs, triangles);

  double worst = 0.0, sum = 0.0;
  for (int frame = 1; frame <= frames; ++frame) {
    // The mouse: a circle of `radius` in the node's parent frame, back home at the last frame.
    const double angle = 2.0 * M_PI * double(frame) / double(frames);
    blobtree::Transform t = home;
    t.translate += radius * glm::dvec3(std::sin(angle), 0.5 * (1.0 - std::cos(angle)), 0.0);
    t0 = std::chrono::steady_clock::now();
    const blobtree::Region region = tree.apply({path, blobtree::SetTransform{t}});
    cpu::IncrementalStats st;
    const mesh::TriMesh& m = mesher.update(tree.program(), region, &st);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    worst = std::max(worst, ms), sum += ms;
    if (check && !(m == cpu::polygonizeMpu(tree.program(), grid))) {
      std::fprintf(stderr, "drag_edit: frame %d differs from a full re-mesh\n", frame);
      return 1;
    }
    triangles = m.triangleCount();
    std::printf("frame %2d: %.2f ms (%zu of %zu MPUs re-run), %zu triangles\n", frame, ms, st.mpusRerun, st.mpus,
                triangles);
  }
  std::printf("%d frames: mean %.2f ms, worst %.2f ms, full re-mesh %.1f ms%s\n", frames, sum / frames, worst, fullMs,
              check ? "; every frame equal to a full re-mesh" : "");
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "drag_edit: %s\n", e.what());
  return 1;
}
