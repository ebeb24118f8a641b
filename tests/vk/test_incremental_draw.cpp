// The engine-facing buffers of an incremental mesh (vk/render/incremental_draw.h): after every
// edit of a random sequence, the device buffers (vertex attributes within the counts, indices)
// must hold a full vk::polygonize of the edited tree byte for byte and the draw command its index
// count; most edits must have patched the buffers in place, counts changing included, copying
// less than the whole mesh. The last frame drawn from the buffers (indirect) must equal the same
// mesh drawn from the host.
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/render/incremental_draw.h"
#include "blobvk/vk/render/render_image.h"
#include "blobvk/vk/render/render_mesh.h"
#include "../blobtree/random_edits.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

class IncrementalDraw : public VulkanTest {};

template <class T, class A>
bool deviceHolds(vk::Device& device, const vk::Buffer& buffer, const std::vector<T, A>& want) {
  if (want.empty()) return true;
  std::vector<T> got(want.size());
  device.download(buffer, got.data(), got.size() * sizeof(T));
  return std::memcmp(got.data(), want.data(), got.size() * sizeof(T)) == 0;
}

TEST_F(IncrementalDraw, BuffersArePatchedInPlaceToTheFullMesh) {
  const blobtree::Scene scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/tower.json");
  blobtree::EditableTree tree(scene.root);
  blobtree::GridRequest request;
  request.resolution = 48;
  const blobtree::GridSpec grid = blobtree::chooseGrid(tree.program(), scene.grid, request);
  vk::GpuPolygonizeOptions options;
  options.brickCells = 4;
  options.traversal = vk::Traversal::Stackless;
  vk::IncrementalExtractor inc(device(), grid, options);
  vk::IncrementalDrawBuffers draw(device(), 1.5);

  vk::IncrementalGpuStats st;
  vk::DrawPatchStats ps;
  const auto patch = [&](const mesh::TriMesh& m) {
    device().run([&](vk::Recorder& rec) {
      ps = draw.record(rec, m, st.verticesChanged, st.trianglesChanged);
      rec.hostBarrier();
    });
  };
  const auto check = [&](const std::string& what) {
    const mesh::TriMesh want = vk::polygonize(device(), tree.program(), grid, inc.options());
    EXPECT_TRUE(deviceHolds(device(), draw.positions(), want.positions)) << what << ": positions";
    EXPECT_TRUE(deviceHolds(device(), draw.normals(), want.normals)) << what << ": normals";
    EXPECT_TRUE(deviceHolds(device(), draw.colours(), want.colours)) << what << ": colours";
    EXPECT_TRUE(deviceHolds(device(), draw.indices(), want.triangles)) << what << ": indices";
    std::uint32_t command[5] = {};
    device().download(draw.drawCommand(), command, sizeof(command));
    EXPECT_EQ(command[0], 3 * want.triangleCount()) << what;
    EXPECT_EQ(command[1], 1u) << what;
  };
  patch(inc.reset(tree.program(), &st));
  EXPECT_FALSE(ps.inPlace);
  check("reset");

  const glm::dvec3 lo(grid.origin), hi = lo + double(grid.cellSize) * glm::dvec3(grid.cells);
  RandomEdits edits(4242, lo, hi);
  int inPlace = 0, inPlaceCountChanged = 0, partialCopy = 0;
  for (int step = 0; step < 10; ++step) {
    const blobtree::Region region = tree.apply(edits.next(tree.root()));
    const std::size_t before = inc.mesh().vertexCount();
    const mesh::TriMesh& m = inc.update(tree.program(), region, &st);
    patch(m);
    check("step " + std::to_string(step));
    if (HasFailure()) return;
    const std::uint64_t meshBytes = m.positions.size() * 36 + m.triangles.size() * 12;
    inPlace += ps.inPlace;
    inPlaceCountChanged += ps.inPlace && m.vertexCount() != before;
    partialCopy += ps.inPlace && ps.bytesCopied < meshBytes;
  }
  EXPECT_GT(inPlace, 5);
  EXPECT_GT(inPlaceCountChanged, 0);
  EXPECT_GT(partialCopy, 0);

  // What an engine draws: the indirect command over the patched buffers.
  vk::MeshRenderer renderer(device(), 128, 96);
  const vk::Camera camera = vk::resolveCamera(tree.program().bounds, std::nullopt, {}, 128.0f / 96.0f);
  const vk::Image fromDevice = renderer.render(draw.view(), camera);
  const vk::Image fromHost = renderer.render(inc.mesh(), camera);
  const vk::ImageDifference diff = vk::compareImages(fromDevice, fromHost, 0.0);
  EXPECT_EQ(diff.fractionOver, 0.0) << "PSNR " << diff.psnr;
}

}  // namespace
}  // namespace blobvk::testing
