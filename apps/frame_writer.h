// Writes the frames of `simulate` and `cut`: frame_NNNNN.ply always and, where a Vulkan device
// is available, frame_NNNNN.png rendered headless with a camera fixed from the first frame.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"
#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"

#include <memory>
#include <optional>
#include <string>

namespace blobvk::app {

// A tet-boundary surface (vertices = the tet mesh's nodes, as fem::boundarySurface makes it, e.g.
// the render surface after a cut) has no colours: give each node the colour of the primitive its
// tets' region names (materialFromPrimitive: region r = primitive r), else the first primitive's.
// Surfaces that already have colours, or whose vertices are not the nodes, are returned as is.
mesh::TriMesh colourByRegion(mesh::TriMesh surface, const mesh::TetMesh& tets, const blobtree::Program& program);

class FrameWriter {
 public:
  // Makes, when `png`, the renderer, then creates `folder` (prepareOutputFolder). Without a
  // Vulkan device PNG frames are left out with a warning, unless `pngRequired` (the user asked
  // for a PNG size): then it throws, and creates nothing.
  FrameWriter(std::string folder, bool png, bool pngRequired, int size, const blobtree::Aabb& bounds,
              const std::optional<blobtree::Camera>& camera);
  ~FrameWriter();
  void write(mesh::TriMesh surface);  // by value: the callers' surfaces are temporaries
  int frames() const { return frame_; }
  bool writesPng() const;

 private:
  struct Renderer;
  std::string folder_;
  int frame_ = 0;
  std::unique_ptr<Renderer> renderer_;
};

}  // namespace blobvk::app
