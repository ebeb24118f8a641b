// drag_edit: what an interactive modeller does with blobvk. It loads a scene, picks a primitive,
// and drags it around a circle, one small move per frame; each frame applies the move as an edit
// (blobtree::EditableTree) and re-meshes only what the move touched: on the CPU
// (cpu::IncrementalPolygonizer, per MPU) or, with --backend vk, on Vulkan
// (vk::IncrementalExtractor, per box of bricks) with the mesh's draw buffers patched in place on
// the device each frame (vk::IncrementalDrawBuffers), as an engine would draw them. It prints
// the frame latency and, with --check, compares every frame's mesh with a full re-mesh of the
// same grid (and, on vk, the device buffers with that mesh).
//
//   drag_edit SCENE [--node ID | --path 0,3,1] [--frames N] [--radius R] [--resolution N]
//             [--backend cpu|vk] [--check]
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/incremental_polygonizer.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#ifdef BLOBVK_DRAG_EDIT_VK
#include "blobvk/vk/device/standalone.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/render/incremental_draw.h"
#endif

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <optional>
#include <memory>
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

// What re-meshes each frame: reset once, then update per edit; `matchesFull` re-meshes the whole
// grid and compares (the --check oracle).
class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::size_t reset(const blobtree::Program& program) = 0;  // triangles
  // Triangles after the edit; `note` says what was re-run.
  virtual std::size_t update(const blobtree::Program& program, const blobtree::Region& region, std::string& note) = 0;
  virtual bool matchesFull(const blobtree::Program& program) = 0;
};

class CpuBackend : public Backend {
 public:
  explicit CpuBackend(const blobtree::GridSpec& grid) : grid_(grid), mesher_(grid) {}
  std::size_t reset(const blobtree::Program& program) override { return mesher_.reset(program).triangleCount(); }
  std::size_t update(const blobtree::Program& program, const blobtree::Region& region, std::string& note) override {
    cpu::IncrementalStats st;
    const std::size_t triangles = mesher_.update(program, region, &st).triangleCount();
    note = std::to_string(st.mpusRerun) + " of " + std::to_string(st.mpus) + " MPUs re-run";
    return triangles;
  }
  bool matchesFull(const blobtree::Program& program) override {
    return mesher_.mesh() == cpu::polygonizeMpu(program, grid_);
  }

 private:
  blobtree::GridSpec grid_;
  cpu::IncrementalPolygonizer mesher_;
};

#ifdef BLOBVK_DRAG_EDIT_VK
// The mesh stays where an engine draws it: after each edit, only the changed ranges of the
// device's vertex and index buffers are rewritten and the indirect draw command's count with them.
class VkBackend : public Backend {
 public:
  explicit VkBackend(const blobtree::GridSpec& grid)
      : context_(std::make_unique<vk::StandaloneContext>()), grid_(grid), mesher_(std::in_place, context_->device(), grid),
        draw_(std::in_place, context_->device()) {}
  ~VkBackend() override {
    draw_.reset();
    mesher_.reset();
    context_.reset();  // before the driver's exit handlers (docs/vulkan.md)
  }
  std::size_t reset(const blobtree::Program& program) override {
    vk::IncrementalGpuStats st;
    const mesh::TriMesh& m = mesher_->reset(program, &st);
    patch(m, st);
    return m.triangleCount();
  }
  std::size_t update(const blobtree::Program& program, const blobtree::Region& region, std::string& note) override {
    vk::IncrementalGpuStats st;
    const mesh::TriMesh& m = mesher_->update(program, region, &st);
    const vk::DrawPatchStats ps = patch(m, st);
    note = std::to_string(st.bricksRerun) + " of " + std::to_string(st.bricks) + " bricks re-run, " +
           (ps.inPlace ? "buffers patched in place (" : "new buffers (") + std::to_string(ps.bytesCopied >> 10) + " KiB)";
    return m.triangleCount();
  }
  bool matchesFull(const blobtree::Program& program) override {
    vk::Device& device = context_->device();
    const mesh::TriMesh full = vk::polygonize(device, program, grid_, mesher_->options());
    if (!(mesher_->mesh() == full)) return false;
    const auto holds = [&](const vk::Buffer& b, const void* want, std::size_t bytes) {
      std::vector<char> got(bytes);
      if (bytes) device.download(b, got.data(), bytes);
      return bytes == 0 || std::memcmp(got.data(), want, bytes) == 0;
    };
    std::uint32_t command[5] = {};
    device.download(draw_->drawCommand(), command, sizeof(command));
    return holds(draw_->positions(), full.positions.data(), full.positions.size() * 12) &&
           holds(draw_->normals(), full.normals.data(), full.normals.size() * 12) &&
           holds(draw_->indices(), full.triangles.data(), full.triangles.size() * 12) &&
           command[0] == 3 * full.triangleCount();
  }

 private:
  vk::DrawPatchStats patch(const mesh::TriMesh& m, const vk::IncrementalGpuStats& st) {
    vk::DrawPatchStats ps;
    context_->device().run([&](vk::Recorder& rec) {
      ps = draw_->record(rec, m, st.verticesChanged, st.trianglesChanged);
      rec.hostBarrier();
    });
    return ps;
  }
  std::unique_ptr<vk::StandaloneContext> context_;
  blobtree::GridSpec grid_;
  std::optional<vk::IncrementalExtractor> mesher_;
  std::optional<vk::IncrementalDrawBuffers> draw_;
};
#endif

std::unique_ptr<Backend> makeBackend(const std::string& name, const blobtree::GridSpec& grid) {
  if (name == "cpu") return std::make_unique<CpuBackend>(grid);
#ifdef BLOBVK_DRAG_EDIT_VK
  if (name == "vk") return std::make_unique<VkBackend>(grid);
  throw std::invalid_argument("--backend: expected cpu or vk, not '" + name + "'");
#else
  throw std::invalid_argument("--backend: expected cpu (this build has no Vulkan), not '" + name + "'");
#endif
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 2) {
    std::fprintf(stderr, "usage: drag_edit SCENE [--node ID | --path 0,3,1] [--frames N] [--radius R] "
                         "[--resolution N] [--backend cpu|vk] [--check]\n");
    return 2;
  }
  std::string node, pathText, backendName = "cpu";
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
    else if (arg == "--backend") backendName = value();
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
  const std::unique_ptr<Backend> mesher = makeBackend(backendName, grid);
  auto t0 = std::chrono::steady_clock::now();
  std::size_t triangles = mesher->reset(tree.program());
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
    std::string note;
    triangles = mesher->update(tree.program(), region, note);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    worst = std::max(worst, ms), sum += ms;
    if (check && !mesher->matchesFull(tree.program())) {
      std::fprintf(stderr, "drag_edit: frame %d differs from a full re-mesh\n", frame);
      return 1;
    }
    std::printf("frame %2d: %.2f ms (%s), %zu triangles\n", frame, ms, note.c_str(), triangles);
  }
  std::printf("%d frames: mean %.2f ms, worst %.2f ms, full re-mesh %.1f ms%s\n", frames, sum / frames, worst, fullMs,
              check ? "; every frame equal to a full re-mesh" : "");
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "drag_edit: %s\n", e.what());
  return 1;
}
