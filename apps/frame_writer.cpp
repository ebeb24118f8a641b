#include "frame_writer.h"

#include "cli_conventions.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/mesh/io.h"
#include "blobvk/mesh/unreferenced.h"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/render/png_io.h"
#include "blobvk/vk/render/render_camera.h"
#include "blobvk/vk/render/render_mesh.h"
#include "blobvk/vk/device/standalone.h"
#endif

namespace blobvk::app {

#ifdef BLOBVK_HAVE_VULKAN
struct FrameWriter::Renderer {
  vk::StandaloneContext context;
  vk::MeshRenderer renderer;
  vk::Camera camera;
  Renderer(int size, const blobtree::Aabb& bounds, const std::optional<blobtree::Camera>& sceneCamera)
      : context(vk::StandaloneOptions{}),
        renderer(context.device(), std::uint32_t(size), std::uint32_t(size)),
        camera(vk::resolveCamera(bounds, sceneCamera, {}, 1.0f)) {}
};
#else
struct FrameWriter::Renderer {};
#endif

FrameWriter::FrameWriter(std::string folder, bool png, bool pngRequired, int size, const blobtree::Aabb& bounds,
                         const std::optional<blobtree::Camera>& camera)
    : folder_(std::move(folder)) {
#ifdef BLOBVK_HAVE_VULKAN
  if (png) {
    try {
      renderer_ = std::make_unique<Renderer>(size, bounds, camera);
    } catch (const std::exception& e) {
      // PNG frames are a bonus; the PLY frames are the product. A size the user gave is a
      // request, though: a run that drops it must not look like a success.
      if (pngRequired) throw std::runtime_error("--image-size " + std::to_string(size) + ": cannot render PNG frames: " + e.what());
      std::fprintf(stderr, "blobvk: warning: no PNG frames: %s\n", e.what());
    }
  }
#else
  if (pngRequired)
    throw std::runtime_error("--image-size " + std::to_string(size) + ": cannot render PNG frames: this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
  if (png) std::fprintf(stderr, "blobvk: warning: no PNG frames: this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)\n");
  (void)bounds;
  (void)camera;
#endif
  // The folder last: a renderer that cannot be made leaves nothing behind.
  prepareOutputFolder(folder_);
}

FrameWriter::~FrameWriter() = default;

mesh::TriMesh colourByRegion(mesh::TriMesh surface, const mesh::TetMesh& tets, const blobtree::Program& program) {
  if (!surface.colours.empty() || surface.positions.size() != tets.nodeCount() || program.primitives.empty()) return surface;
  std::vector<mesh::Float3> palette;
  for (const auto& prim : program.primitives) {
    const glm::vec3 c = blobtree::unpackColour(prim.meta.z);
    palette.push_back({c.x, c.y, c.z});
  }
  surface.colours.assign(surface.positions.size(), palette.front());
  if (tets.regions.size() == tets.tetCount()) {
    for (std::size_t t = 0; t < tets.tetCount(); ++t) {
      const mesh::Float3 c = palette[std::min<std::size_t>(tets.regions[t], palette.size() - 1)];
      for (std::uint32_t node : tets.tets[t]) surface.colours[node] = c;
    }
  }
  return surface;
}

bool FrameWriter::writesPng() const { return renderer_ != nullptr; }

void FrameWriter::write(mesh::TriMesh surface) {
  char name[64];
  std::snprintf(name, sizeof name, "frame_%05d", frame_++);
  const std::filesystem::path base = std::filesystem::path(folder_) / name;
  // A tet-boundary surface carries every node of its tet mesh; the file holds the surface's own.
  mesh::dropUnreferencedVertices(surface);
  mesh::writePly(surface, base.string() + ".ply");
#ifdef BLOBVK_HAVE_VULKAN
  if (renderer_ && surface.triangleCount() > 0) {
    writeOutput(base.string() + ".png", vk::encodePng(renderer_->renderer.render(surface, renderer_->camera)));
  }
#endif
}

}  // namespace blobvk::app
