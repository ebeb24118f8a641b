// blobvk's Vulkan embedding API: polygonize and render implicit models inside a host engine.
// Style of VulkanMemoryAllocator and Dear ImGui's Vulkan backend: the host owns every Vulkan
// object it passes in, the library records into the host's command buffers, and the host
// submits. examples/embed_host/main.cpp is a complete, tested host in ~500 lines.
//
// ---- 1. Hand over the device --------------------------------------------------------------
//   blobvk::vk::HostContext host;            // all handles stay the host's; they must outlive
//   host.instance = ...; host.physicalDevice = ...; host.device = ...;     // the Device below
//   host.queueFamilyIndex = family;          // compute (and graphics, for the mesh renderer)
//   host.queue = queue;                      // only for blobvk's upload/one-shot helpers
//   host.getInstanceProcAddr = vkGetInstanceProcAddr;   // any loader: volk, static, dynamic
//   host.instanceApiVersion = VK_API_VERSION_1_1;  // your VkApplicationInfo::apiVersion (>= 1.1)
//   host.pipelineCache = engineCache;        // optional: pipelines go into it; never destroyed
//   blobvk::vk::Device device(host);         // private dispatch table, allocator, pipelines
// Requirements: Vulkan 1.1 (instance and device), subgroup vote in compute shaders, no extension
// and no optional feature; the Device constructor refuses what lacks them, naming it. The
// library loads its own function pointers through getInstanceProcAddr; it never calls global
// vk* prototypes.
//
// ---- 2. Record the polygonizer into your command buffer -------------------------------------
//   blobvk::vk::SlabPolygonizer poly(device, program, grid, {});   // single slab: plan(0)
//   blobvk::vk::Recorder rec(device, cmd);   // keep alive until cmd has executed (descriptors)
//   poly.recordClassify(rec, 0, 0, 0);       // field, flags, scans, draw arguments
//   poly.recordEmit(rec, 0, 0, {positions, normals, colours, keys, indices, maxVertices, maxTriangles});
//   // then vkCmdDrawIndexedIndirect(cmd, poly.drawArgs().handle(), 0, 1, 0) in your pass.
// Capacity: a mesh has at most 3 vertices per grid point and 5 triangles per cell
// (SlabPlan::ownedPoints, SlabPlan::cells); allocate that, or read back drawArgs() words 5 and 6
// after recordClassify to size the buffers exactly (vk/render/render_gpu_mesh.h does both). The emit
// pass never writes past the capacities you pass; a mesh that does not fit sets drawArgs() word
// kOverflowWord (SlabPolygonizer::readOverflow()) and is left out of the indirect draw.
//
// ---- 3. Barriers: what the library expects and leaves --------------------------------------
//  - Expects: nothing pending on the buffers it is given (your earlier writes to them finished
//    with a barrier to COMPUTE_SHADER); Program buffers are uploaded at construction, by a
//    blocking submit when they are not host visible unless a vk::UploadBatch is open: then
//    batch.record(cmd) records the copies and a TRANSFER -> COMPUTE_SHADER|TRANSFER barrier
//    (docs/embedding.md, point 7).
//  - Leaves (after every record* call): its shader writes made available to COMPUTE_SHADER,
//    TRANSFER and DRAW_INDIRECT (SHADER_READ|WRITE, TRANSFER_READ|WRITE, INDIRECT_COMMAND_READ).
//    To draw, add VERTEX_INPUT (VERTEX_ATTRIBUTE_READ | INDEX_READ) yourself, as embed_host does.
//  - Images: the headless mesh renderer (vk/render/render_mesh.h: MeshPipeline::recordDraw) records
//    inside YOUR render pass when you pass it at construction; OffscreenTarget documents its own
//    layouts (attachments from UNDEFINED, resolved colour left in TRANSFER_SRC_OPTIMAL).
//  - The ray-caster (vk/render/raycast.h: Raycaster::recordRaycast) writes packed RGBA8 into a buffer
//    you give it and leaves the same compute barrier; rays that ran out of steps are drawn
//    kRaycastBudgetMarker and counted (Raycaster::exhaustedRays() once the work completed).
//
// ---- 4. Threads ------------------------------------------------------------------------------
//  - No global state: two Devices (even on the same VkDevice) are independent; the library
//    sets no environment variable. ~Device waits only on its own fence, never vkDeviceWaitIdle.
//  - A Device, and everything created from it, is externally synchronised: use it from one
//    thread at a time (it caches pipelines and sub-allocates memory without locks).
//  - Recording with different Devices into different command buffers from different threads is
//    safe. Device::submitAndWait/run/upload/download use host.queue: the host must not submit
//    to that queue concurrently (Vulkan requires external synchronisation of queues).
//
// ---- 5. Headless convenience -------------------------------------------------------------------
//   blobvk::vk::StandaloneContext ctx({.validation = true});   // own instance + device
//   blobvk::vk::MeshRenderer renderer(ctx.device(), 512, 512); // MSAA, Blinn-Phong, PNG-ready
//   auto image = renderer.render(mesh, camera);  blobvk::vk::writePng("out.png", image);
//
// CMake: find_package(blobvk COMPONENTS vk) then target_link_libraries(app PRIVATE blobvk::vk).
#pragma once

#include "blobvk/blobvk.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/render/png_io.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/multi_device.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/render/incremental_draw.h"
#include "blobvk/vk/render/raycast.h"
#include "blobvk/vk/render/render_camera.h"
#include "blobvk/vk/render/render_gpu_mesh.h"
#include "blobvk/vk/render/render_mesh.h"
#include "blobvk/vk/extract/slab_polygonizer.h"
#include "blobvk/vk/device/standalone.h"
