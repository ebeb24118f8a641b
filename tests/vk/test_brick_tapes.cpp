// Per-brick tapes (vk/eval/region_tape.h, vk/extract/brick_tapes.h): the program pruned on the
// host to the points of one region. Checked against the whole program on the CPU evaluator at
// points of the region (the tape runs as a Program with the same records plus the empty box),
// and on the device: the sparse extraction with tapes gives the CPU reference's mesh, index by
// index, and the bytes of the run without them.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/gradient.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/region_tape.h"
#include "blobvk/vk/extract/brick_tapes.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

// The tape as a Program: the same records, the empty box appended where uploadProgram puts it.
blobtree::Program tapeProgram(const blobtree::Program& program, std::vector<layout::Instruction> tape) {
  blobtree::Program p = program;
  p.code = std::move(tape);
  p.boxes.push_back(vk::emptySkipBox());
  return p;
}

std::vector<std::string> tapeScenes() { return {"random128", "tower", "tower_L6P8I4", "eggshell", "dice"}; }

// `root` compiled, on its default grid with `resolution` cells along the longest side.
ShippedScene compiledModel(const blobtree::Node& root, int resolution) {
  ShippedScene s{blobtree::compile(root), {}};
  blobtree::GridRequest request;
  request.resolution = resolution;
  s.grid = blobtree::chooseGrid(s.program, {}, request);
  return s;
}

// 64 small rotated and stretched subtrees (a box blended with a point, each under its own skip
// box) on a 4 x 4 x 4 lattice, joined by `op` (a union or a difference): a scattering of
// instances, where a region of 16 cells meets a few subtrees and every other child of the
// operator is a "write 0" and its combination. A difference keeps a long bar as its first child
// and cuts it with the rest.
ShippedScene scatteredSubtrees(blobtree::OperatorType op, int resolution) {
  using namespace blobtree;
  std::vector<Node> children;
  if (op == OperatorType::Difference) {
    Node bar;
    Primitive line;
    line.type = PrimitiveType::Line;
    line.a = Vec3(-1.0, 4.5, 4.5);
    line.b = Vec3(10.0, 4.5, 4.5);
    line.support = 1.5;
    bar.kind = line;
    children.push_back(bar);
  }
  for (int i = 0; i < 64; ++i) {
    Node box, point, pair;
    Primitive cube;
    cube.type = PrimitiveType::Cube;
    cube.b = Vec3(0.3, 0.1, 0.3);
    cube.support = 0.5;
    cube.colour = Vec3(0.2 + 0.01 * i, 0.5, 0.9 - 0.01 * i);
    box.kind = cube;
    Primitive centre;
    centre.a = Vec3(0.0, 0.4, 0.0);
    centre.support = 0.7;
    point.kind = centre;
    pair.kind = Operator{OperatorType::Blend};
    pair.children = {box, point};
    pair.transform.translate = Vec3(3.0 * (i % 4), 3.0 * (i / 4 % 4), 3.0 * (i / 16));
    pair.transform.rotate = glm::angleAxis(0.4 * i, glm::normalize(Vec3(1.0, 0.3 * (i % 3), 0.7)));
    pair.transform.scale = Vec3(1.0, 0.8 + 0.02 * i, 1.0);
    children.push_back(pair);
  }
  Node root;
  root.kind = Operator{op};
  root.children = std::move(children);
  return compiledModel(root, resolution);
}

struct TapeScene {
  std::string name;
  ShippedScene scene;
  bool prunes;  // whether a region of 16 cells runs a small part of the program
};

std::vector<TapeScene> tapeTestScenes() {
  std::vector<TapeScene> scenes;
  for (const std::string& name : tapeScenes())
    scenes.push_back({name, shipped(name, 128), name == "random128" || name == "tower" || name == "tower_L6P8I4"});
  scenes.push_back({"scattered union", scatteredSubtrees(blobtree::OperatorType::Union, 128), true});
  scenes.push_back({"scattered difference", scatteredSubtrees(blobtree::OperatorType::Difference, 128), true});
  // A Ricci blend raises each child to its power before adding it: a missed child goes with both.
  scenes.push_back({"Ricci blend of 128", compiledModel(blobtree::generateRandomRicciBlobs(128, 5, 4.0), 128), true});
  return scenes;
}

// Regions of 16 cells at random places of the scene's grid at 128 cells (and one at each
// corner of the grid, mostly empty), with points drawn inside each, corners included.
TEST(RegionTape, GivesTheProgramsFieldAtEveryPointOfItsRegion) {
  std::mt19937 rng(7);
  for (const auto& [name, s, prunes] : tapeTestScenes()) {
    const std::uint32_t emptyBox = std::uint32_t(s.program.boxes.size());
    std::uint64_t tapeLength = 0, programLength = 0;
    for (int r = 0; r < 24; ++r) {
      std::array<std::uint32_t, 3> lo{}, hi{};
      for (int a = 0; a < 3; ++a) {
        const std::uint32_t n = std::uint32_t(s.grid.cells[a]);
        lo[a] = r == 0 ? 0 : std::uniform_int_distribution<std::uint32_t>(0, n > 16 ? n - 16 : 0)(rng);
        hi[a] = lo[a] + 16;
      }
      const vk::PointRegion region = vk::regionOfPoints(s.grid, lo, hi);
      for (vk::TapeUse use : {vk::TapeUse::Field, vk::TapeUse::Exact}) {
        std::vector<layout::Instruction> tape;
        const std::uint32_t length = vk::appendRegionTape(s.program.code, s.program, region, emptyBox, use, tape);
        ASSERT_EQ(length, tape.size());
        // A tape of a tape is the same tape (the walk keeps nothing it could prune again).
        std::vector<layout::Instruction> again;
        vk::appendRegionTape(tape, s.program, region, emptyBox, use, again);
        EXPECT_EQ(again.size(), tape.size()) << name;
        if (use == vk::TapeUse::Field) {
          tapeLength += tape.size();
          programLength += s.program.code.size();
        }
        const blobtree::Program t = tapeProgram(s.program, tape);
        for (int k = 0; k < 64; ++k) {
          glm::vec3 p;
          for (int a = 0; a < 3; ++a) {
            // Grid points (what the field pass evaluates) and points between them (the vertex pass).
            const float i = k < 8 ? float((k >> a & 1) ? hi[a] : lo[a])
                                  : std::uniform_real_distribution<float>(float(lo[a]), float(hi[a]))(rng);
            p[a] = s.grid.origin[a] + s.grid.cellSize * (k < 32 ? std::round(i) : i);
          }
          const std::string what = name + " region " + std::to_string(r) + " point " + std::to_string(k);
          if (use == vk::TapeUse::Field) {
            EXPECT_EQ(blobtree::evaluate(t, p), blobtree::evaluate(s.program, p)) << what;
          } else {  // bit for bit: field, colour and gradient
            const auto a = blobtree::evaluateWithColour(t, p), b = blobtree::evaluateWithColour(s.program, p);
            EXPECT_EQ(std::bit_cast<std::uint32_t>(a.field), std::bit_cast<std::uint32_t>(b.field)) << what;
            for (int c = 0; c < 3; ++c)
              EXPECT_EQ(std::bit_cast<std::uint32_t>(a.colour[c]), std::bit_cast<std::uint32_t>(b.colour[c])) << what;
            const auto ga = blobtree::evaluateGradientColour(t, p), gb = blobtree::evaluateGradientColour(s.program, p);
            for (int c = 0; c < 3; ++c)
              EXPECT_EQ(std::bit_cast<std::uint32_t>(ga.gradient[c]), std::bit_cast<std::uint32_t>(gb.gradient[c]))
                  << what;
          }
        }
      }
    }
    // What the tapes are for: in a scene of many primitives, a region of 16 cells runs a fraction
    // of the program (eggshell and dice are a few primitives all near every region). Under a
    // union, intersection or difference, the children a region misses leave one "write 0" and
    // its combination, not one each.
    if (prunes) {
      EXPECT_LT(tapeLength * 4, programLength) << name << ": tapes of " << tapeLength << " instructions";
    }
  }
}

// A skip whose box misses the region leaves one "write 0" (its subtree gone); a skip whose box
// holds the region leaves its subtree without the test; a missing primitive added to another
// goes with its addition (field tapes only).
TEST(RegionTape, PrunesSubtreesSkipsAndAddedZeros) {
  const ShippedScene s = shipped("random128", 128);
  const std::uint32_t emptyBox = std::uint32_t(s.program.boxes.size());
  vk::PointRegion far;  // beyond every primitive
  far.valid = true;
  for (int a = 0; a < 3; ++a) far.lo[a] = far.hi[a] = 1000.0f;
  std::vector<layout::Instruction> tape;
  ASSERT_EQ(vk::appendRegionTape(s.program.code, s.program, far, emptyBox, vk::TapeUse::Field, tape), 1u);
  EXPECT_EQ(tape[0].code.x & 0xffu, layout::OP_SKIP);
  EXPECT_EQ(tape[0].code.y, emptyBox);
  EXPECT_EQ(tape[0].code.w, 1u);
  // The whole grid: nothing to prune but the root skip, whose box holds every grid point.
  vk::PointRegion all;
  all.valid = true;
  for (int a = 0; a < 3; ++a) {
    all.lo[a] = s.program.bounds.lo[a] + 0.01f;
    all.hi[a] = s.program.bounds.hi[a] - 0.01f;
  }
  tape.clear();
  vk::appendRegionTape(s.program.code, s.program, all, emptyBox, vk::TapeUse::Exact, tape);
  EXPECT_EQ(tape.size(), s.program.code.size() - 1);
}

// A vertex tape keeps every instruction of the exact tape but folds each run of pairs (a
// primitive that is 0 in the region, its addition into one register) into one OP_NULL_ADDS: in a
// small region of random128 (a blend of 128 points) most of the blend is such runs.
TEST(RegionTape, VertexTapesFoldRunsOfPrunedAdditions) {
  const ShippedScene s = shipped("random128", 128);
  const std::uint32_t emptyBox = std::uint32_t(s.program.boxes.size());
  const vk::PointRegion region = vk::regionOfPoints(s.grid, {56, 56, 56}, {72, 72, 72});
  std::vector<layout::Instruction> exact, vertex;
  vk::appendRegionTape(s.program.code, s.program, region, emptyBox, vk::TapeUse::Exact, exact);
  vk::appendRegionTape(s.program.code, s.program, region, emptyBox, vk::TapeUse::Vertex, vertex);
  std::size_t runs = 0, pairs = 0;
  for (const layout::Instruction& in : vertex) {
    if ((in.code.x & 0xffu) != layout::OP_NULL_ADDS) continue;
    ++runs;
    pairs += in.code.w;
    EXPECT_GE(in.code.w, 1u);
    EXPECT_LT(in.code.y, s.program.primitives.size());
  }
  EXPECT_GT(runs, 0u);
  EXPECT_EQ(vertex.size() + 2 * pairs - runs, exact.size()) << "each run of w pairs: 2w instructions as one";
  EXPECT_LT(vertex.size() * 4, exact.size()) << "most of the blend is away from the region";
}

// Windows of uniform blocks: each brick's tape, run with its window's renumbered records, gives
// the program's field at the brick's points; tower_L6P8I4's records (2,400 primitives) are over a
// block, so they only fit once pruned, and its bricks take several windows.
TEST(UniformTapes, EachWindowsRecordsGiveTheProgramsFieldInItsBricks) {
  const ShippedScene s = shipped("tower_L6P8I4", 96);
  vk::BrickGrid bg;
  bg.log2B = 3;
  bg.x = std::uint32_t(s.grid.cells.x + 7) / 8;
  bg.y = std::uint32_t(s.grid.cells.y + 7) / 8;
  bg.z = std::uint32_t(s.grid.cells.z + 7) / 8;
  std::vector<std::uint32_t> bricks;
  for (std::uint32_t z = 0; z < bg.z; ++z)
    for (std::uint32_t y = 0; y < bg.y; ++y)
      for (std::uint32_t x = 0; x < bg.x; ++x)
        if ((x + 3 * y + 5 * z) % 4 == 0) bricks.push_back(bg.pack({x, y, z}));
  vk::UniformTapes u;
  ASSERT_TRUE(vk::buildUniformTapes(s.program, s.grid, bg, bricks, u));
  ASSERT_GT(u.windows.size(), 1u);
  EXPECT_EQ(u.windows.front().firstBrick, 0u);
  EXPECT_EQ(u.windows.back().endBrick, bricks.size());
  std::mt19937 rng(3);
  for (std::size_t w = 0; w < u.windows.size(); ++w) {
    EXPECT_LT(u.windows[w].firstBrick, u.windows[w].endBrick);
    if (w + 1 < u.windows.size()) {
      EXPECT_EQ(u.windows[w].endBrick, u.windows[w + 1].firstBrick);
    }
    blobtree::Program local = s.program;
    auto block = [w](const auto& all, std::size_t n) {
      return std::vector(all.begin() + std::ptrdiff_t(w * n), all.begin() + std::ptrdiff_t((w + 1) * n));
    };
    local.primitives = block(u.primitives, vk::kUniformTapePrims);
    local.matrices = block(u.matrices, vk::kUniformTapeMatrices);
    local.boxes = block(u.boxes, vk::kUniformTapeBoxes);
    local.warps = block(u.warps, vk::kUniformTapeWarps);
    const std::vector<layout::Instruction> code = block(u.code, vk::kUniformTapeCode);
    for (std::uint32_t a = u.windows[w].firstBrick; a < u.windows[w].endBrick; a += 7) {
      const std::uint32_t begin = u.ranges[2 * a], end = u.ranges[2 * a + 1];
      ASSERT_LE(end, vk::kUniformTapeCode);
      // The tape with its skip targets counted from its first instruction, as a Program.
      local.code.assign(code.begin() + begin, code.begin() + end);
      for (layout::Instruction& in : local.code)
        if ((in.code.x & 0xffu) == layout::OP_SKIP) in.code.w -= begin;
      const std::array<std::uint32_t, 3> b = bg.unpack(bricks[a]);
      for (int k = 0; k < 12; ++k) {
        glm::vec3 p;
        for (int i = 0; i < 3; ++i) {
          const std::uint32_t step = k < 8 ? ((k >> i & 1) ? 8u : 0u) : std::uniform_int_distribution<std::uint32_t>(0, 8)(rng);
          p[i] = s.grid.origin[i] + s.grid.cellSize * float(b[i] * 8 + step);
        }
        EXPECT_EQ(blobtree::evaluate(local, p), blobtree::evaluate(s.program, p)) << "window " << w << " brick " << a;
      }
    }
  }
}

// The device: with tapes (the field's, and the vertex pass's with TapeUse::Vertex), the mesh of
// every case is the CPU reference's and the bytes of the whole program's passes, in one batch and
// in batches of a few bricks.
TEST_F(VulkanTest, BrickTapesGiveTheMeshOfTheWholeProgram) {
  struct Case {
    std::string what;
    blobtree::Program program;
    blobtree::GridSpec grid;
  };
  std::vector<Case> cases;
  for (const char* name : {"random128", "tower", "tower_L6P8I4", "dice", "craniotomy"}) {
    ShippedScene s = shipped(name, name == std::string("tower_L6P8I4") ? 40 : 48);
    cases.push_back({name, std::move(s.program), s.grid});
  }
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/legacy/tower_fragment.blob");
  Case legacy{"tower_fragment.blob", blobtree::compile(scene.root), {}};
  blobtree::GridRequest request;
  request.resolution = 64;
  legacy.grid = blobtree::chooseGrid(legacy.program, scene.grid, request);
  cases.push_back(std::move(legacy));
  for (blobtree::OperatorType op : {blobtree::OperatorType::Union, blobtree::OperatorType::Difference}) {
    ShippedScene s = scatteredSubtrees(op, 48);
    cases.push_back({op == blobtree::OperatorType::Union ? "scattered union" : "scattered difference",
                     std::move(s.program), s.grid});
  }
  for (const Case& c : cases) {
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Stackless;
    o.brickCells = 8;
    const mesh::TriMesh whole = vk::polygonize(device(), c.program, c.grid, o);
    expectSameMeshAsReference(whole, cpu::polygonizeReference(c.program, c.grid, {}), 1e-4f * c.grid.cellSize, c.what);
    o.brickTapes = true;
    for (std::uint32_t batchBricks : {0u, 9u})
    for (bool uniforms : {true, false}) {
      o.maxBatchBricks = batchBricks;
      o.brickTapeUniforms = uniforms;
      vk::GpuStats st;
      const mesh::TriMesh m = vk::polygonize(device(), c.program, c.grid, o, &st);
      const std::string what = c.what + ", batches of " + std::to_string(batchBricks) + " bricks, " +
                               (uniforms ? "uniform blocks" : "storage buffer");
      EXPECT_GT(st.tapeInstructions, 0u) << what;
      EXPECT_TRUE(st.vertexTapes) << what << ": the vertex pass over the bricks' vertex tapes";
      // On a CPU device the vertex tapes go to windows of uniform blocks with the field's, at
      // least one a batch.
      if (device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU && uniforms) {
        EXPECT_GT(st.vertexTapeWindows, 0u) << what;
        // tower_L6P8I4's tapes fill several windows in one batch.
        if (batchBricks == 0 && c.what == "tower_L6P8I4") {
          EXPECT_GT(st.vertexTapeWindows, 1u) << what;
        }
      }
      if (!uniforms) {
        EXPECT_EQ(st.vertexTapeWindows, 0u) << what;
      }
      // One batch: each active brick's tape counted once; a scene of many primitives runs a fraction.
      if (batchBricks == 0 && (c.what == "random128" || c.what == "tower" || c.what == "tower_L6P8I4" ||
                               c.what == "scattered union")) {
        EXPECT_LT(st.tapeInstructions * 2, std::uint64_t(st.activeBricks) * c.program.code.size()) << what;
      }
      expectSameBytes(m, whole, what);
    }
  }
}

// Under Auto on lavapipe a looped program runs its field over the tapes where they beat its
// looped code: a flat blend of 600 points (1,200 instructions with nothing for looped code to
// skip; a few tens on each brick's tape; at 64 cells field 7.4 s -> 0.26 s), and its vertex pass,
// whose looped code brings no gradient, interprets the gradient from uniform blocks. A program
// short enough to unroll takes no tapes. The mesh is the MPU polygonizer's, byte for byte.
TEST_F(VulkanTest, AutoRunsALoopedFlatBlendsFieldOverBrickTapes) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the model's constants are lavapipe's";
  blobtree::GridRequest request;
  request.resolution = 40;
  const blobtree::Program flat = blobtree::compile(blobtree::generateRandomBlobs(600, 1));
  ASSERT_GT(flat.code.size(), 1000u);
  const blobtree::GridSpec grid = blobtree::chooseGrid(flat, {}, request);
  vk::GpuPolygonizeOptions o;  // Auto
  vk::GpuStats st;
  const mesh::TriMesh m = vk::polygonize(device(), flat, grid, o, &st);
  EXPECT_EQ(st.traversal, vk::Traversal::Specialised);
  EXPECT_GT(st.tapeInstructions, 0u) << "the field over tapes";
  EXPECT_LT(st.tapeInstructions * 4, std::uint64_t(st.activeBricks) * flat.code.size()) << "tapes a fraction of the program";
  EXPECT_TRUE(st.vertexTapes) << "the looped program's gradient interpreted from the bricks' vertex tapes";
  EXPECT_FALSE(st.vertexGradient);
  EXPECT_GT(st.tapeBytes, 0u);
  EXPECT_LE(st.deviceBytes, vk::sparseDeviceBytes(vk::brickGridFor(grid, st.brickCells), st.activeBricks,
                                                  m.positions.size(), m.triangles.size(), true, true, st.tapeBytes));
  const mesh::TriMesh cpu = cpu::polygonizeMpu(flat, grid);
  ASSERT_GT(cpu.triangleCount(), 1000u);
  EXPECT_TRUE(sameBytes(m.positions, cpu.positions));
  EXPECT_TRUE(sameBytes(m.normals, cpu.normals));
  EXPECT_TRUE(sameBytes(m.colours, cpu.colours));
  EXPECT_TRUE(sameBytes(m.triangles, cpu.triangles));

  const blobtree::Program short_ = blobtree::compile(blobtree::generateRandomBlobs(100, 1));
  vk::GpuStats unrolled;
  vk::polygonize(device(), short_, blobtree::chooseGrid(short_, {}, request), o, &unrolled);
  EXPECT_EQ(unrolled.tapeInstructions, 0u) << "unrolled code: no tapes";
}

// Without field tapes, a looped program's vertex pass may still interpret each vertex's brick's
// vertex tape where it would run the whole program's looped code (GpuPolygonizeOptions::
// vertexTapes): the bytes of the looped pass and of the MPU polygonizer, on a flat blend and on a
// tower of repeated storeys (looped code of 808 instructions, skips it takes).
TEST_F(VulkanTest, LoopedVertexPassOverVertexTapesGivesTheSameMesh) {
  blobtree::GridRequest request;
  request.resolution = 40;
  struct Case {
    std::string what;
    blobtree::Program program;
  };
  for (const Case& c : {Case{"flat blend of 300", blobtree::compile(blobtree::generateRandomBlobs(300, 2))},
                        Case{"tower L3P8G2", blobtree::compile(blobtree::generateTower(3, 8, 6.0, 6.0, 2))}}) {
    ASSERT_GT(c.program.code.size(), 500u) << c.what;
    const blobtree::GridSpec grid = blobtree::chooseGrid(c.program, {}, request);
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Specialised;  // looped code on a CPU driver
    o.maxFieldTiles = 1;
    vk::GpuStats looped, taped;
    const mesh::TriMesh a = vk::polygonize(device(), c.program, grid, o, &looped);
    o.vertexTapes = true;
    const mesh::TriMesh b = vk::polygonize(device(), c.program, grid, o, &taped);
    if (device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU) {
      EXPECT_FALSE(looped.vertexTapes) << c.what;
      EXPECT_TRUE(taped.vertexTapes) << c.what;
      EXPECT_EQ(taped.tapeInstructions, 0u) << c.what << ": the field keeps its kernel";
    }
    ASSERT_GT(a.triangleCount(), 1000u) << c.what;
    expectSameBytes(b, a, c.what);
    const mesh::TriMesh cpu = cpu::polygonizeMpu(c.program, grid);
    EXPECT_TRUE(sameBytes(b.triangles, cpu.triangles)) << c.what;
    if (device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU) {
      EXPECT_TRUE(sameBytes(b.positions, cpu.positions)) << c.what;
      EXPECT_TRUE(sameBytes(b.normals, cpu.normals)) << c.what;
      EXPECT_TRUE(sameBytes(b.colours, cpu.colours)) << c.what;
    } else {  // other drivers' exp and division round otherwise (docs/vulkan.md)
      expectSameMeshWithin(b, cpu, referenceToleranceCells(false) * grid.cellSize, 1e-2f, 1e-3f, c.what);
    }
  }
}

// Auto takes the vertex tapes for a looped program. From a storage buffer only where a point of a
// brick would run many times its brick's tape: a flat blend (1,200 instructions, nothing looped
// code can skip; tens on a tape), not a tower of repeated storeys (its skips leave about a tape's
// worth). From windows of uniform blocks (lavapipe) always: the tower's vertex pass runs 1.4x
// faster there than looped (L3P8G2 at 256 cells, docs/performance.md).
TEST_F(VulkanTest, AutoTakesVertexTapesForLoopedProgramsWhereTheyPay) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the model's constants are lavapipe's";
  blobtree::GridRequest request;
  request.resolution = 64;
  auto resolve = [&](const blobtree::Program& program, bool uniforms) {
    const blobtree::GridSpec grid = blobtree::chooseGrid(program, {}, request);
    vk::GpuStats cs;
    const vk::ClassifiedBricks classified =
        vk::classifyAndCompact(device(), program, grid, vk::brickGridFor(grid, 16), cs);
    vk::GpuPolygonizeOptions o;  // Auto
    o.brickTapeUniforms = uniforms;  // false: no field tapes, the vertex tapes in a storage buffer
    return vk::resolveSparseEvaluator(device(), program, grid, o, &classified);
  };
  const blobtree::Program flatProgram = blobtree::compile(blobtree::generateRandomBlobs(600, 1));
  const blobtree::Program towerProgram = blobtree::compile(blobtree::generateTower(3, 8, 6.0, 6.0, 2));
  const vk::SparseEvaluator flat = resolve(flatProgram, false);
  EXPECT_EQ(flat.traversal, vk::Traversal::Specialised);
  EXPECT_FALSE(flat.brickTapes);
  EXPECT_TRUE(flat.vertexTapes);
  EXPECT_TRUE(flat.apply({}).vertexTapes);
  const vk::SparseEvaluator tower = resolve(towerProgram, false);
  EXPECT_EQ(tower.traversal, vk::Traversal::Specialised);
  EXPECT_FALSE(tower.vertexTapes);
  // With windows the tower's vertex pass runs over them (with the field's tapes, or alone).
  vk::GpuPolygonizeOptions o;  // Auto
  vk::GpuStats st;
  const blobtree::GridSpec grid = blobtree::chooseGrid(towerProgram, {}, request);
  const mesh::TriMesh m = vk::polygonize(device(), towerProgram, grid, o, &st);
  EXPECT_TRUE(st.vertexTapes);
  EXPECT_GT(st.vertexTapeWindows, 0u);
  expectSameMeshAsReference(m, cpu::polygonizeReference(towerProgram, grid, {}), 1e-4f * grid.cellSize, "tower L3P8G2");
}

}  // namespace
}  // namespace blobvk::testing
