// blobvk — BlobTree implicit models to meshes and images. Public entry header of the core
// (no Vulkan): build a tree or load a scene, compile it to a Program, evaluate or polygonize it.
//
//   #include <blobvk/blobvk.h>
//   auto scene   = blobvk::blobtree::loadScene("tower.json");
//   auto program = blobvk::blobtree::compile(scene.root);          // the flat, stackless tape
//   auto grid    = blobvk::blobtree::chooseGrid(program, scene.grid, {});
//   float f      = blobvk::blobtree::evaluate(program, {0, 1, 0}); // inside where f >= 0.5
//
// CMake: find_package(blobvk COMPONENTS cpu) then target_link_libraries(app PRIVATE blobvk::cpu)
// (blobvk::blobtree, blobvk::mesh come with it; COMPONENTS vk and blobvk::vk for the GPU, see
// <blobvk/vulkan.h>).
//
// Thread safety: Program, Tree and GridSpec are plain values; evaluating one Program from many
// threads at once is safe (const access only). No global state needs setting up or tearing down:
// what is process-wide is thread-safe caches of host-side plans and per-thread scratch buffers.
#pragma once

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/blobtree/tree.h"
#include "blobvk/mesh/trimesh.h"
