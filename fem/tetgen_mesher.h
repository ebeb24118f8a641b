// Constrained Delaunay tetrahedralization of a closed surface with TetGen 1.5. TetGen is AGPL:
// it is linked only when the CMake option BLOBVK_WITH_TETGEN is ON, and only tetgen_mesher.cpp
// includes it. Without it, tetrahedralize() throws and tetgenAvailable() is false.
#pragma once

#include "blobvk/fem/tetgen_slivers.h"
#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"

#include <cstdint>
#include <string>
#include <vector>

namespace blobvk::fem {

struct TetgenOptions {
  double maxRadiusEdgeRatio = 1.414;  // -q<ratio>; >= 1.0 (TetGen may not terminate below)
  double minDihedralDegrees = 10.0;   // -q<ratio>/<angle>; heuristic, 0 = TetGen default
  double maxVolume = 0.0;             // -a<volume>; 0 = unbounded
  // -S<n>: TetGen adds at most this many points (Steiner points, inside and on the boundary),
  // about six tets each, so refinement ends even where -q's bounds cannot be met: TetGen need
  // not terminate for a radius-edge bound near 1 or a dihedral bound near 30 degrees (measured:
  // 50 MB/s of growth without end). 0 = no limit. A maxVolume that asks for more tets than the
  // limit allows is refused before TetGen runs. At most 2^31 - 1 (TetGen's int).
  std::uint32_t maxAddedPoints = 200000;
  bool quality = true;                // false: no -q (boundary-conforming CDT only)
  bool keepSurface = false;           // -Y: no Steiner points on the boundary
  // -o/<angle>: the largest dihedral angle TetGen's mesh optimization aims for; 0 = TetGen's
  // default (165). 140-150 removes the slivers that -q/<angle> alone leaves once -a adds many
  // interior points (measured: min dihedral 7.2 -> 12.7 degrees at ~100k tets, same time; see
  // docs/performance.md). It cannot fix tets forced by thin input triangles.
  double optimizeMaxDihedralDegrees = 0.0;
  // After TetGen, move Steiner points around the tets still below minDihedralDegrees
  // (fem/tetgen_slivers.h): TetGen leaves a few (7.5-9.9 degrees in 85k-215k tets, measured).
  bool smoothSlivers = true;
  // Points inside cavities of the domain (TetGen's hole list): TetGen fills every region the
  // surface encloses, so a shell's hollow (the eggshell's inside, the gap between skull and
  // brain) needs one point in it to come out empty. Not part of the switch string.
  std::vector<mesh::Double3> holes;
  // TetGen runs in a forked child process, so that its crashes (it still segfaults on some valid
  // closed surfaces) become std::runtime_error instead of taking the host down. The isolation
  // costs with the host's memory, not the surface: fork copies the page tables, and the host's
  // pages take a copy-on-write fault each when next written (docs/fem.md: +2.5 ms a call for a
  // small host; a host holding 2 GiB +82 ms, then 0.46 s of faults as it writes its memory).
  // false: TetGen runs in the calling thread (the same mesh, bit for bit), for a host that
  // meshes trusted surfaces often and holds much memory.
  bool isolateInChildProcess = true;
};

bool tetgenAvailable();
// The TetGen switch string these options produce (always with p, z (0-based) and Q (quiet)).
std::string tetgenSwitches(const TetgenOptions& options);
// Throws std::invalid_argument when options.maxVolume asks for more tets in a body of `volume`
// than options.maxAddedPoints allows (about 6 tets per added point; none when either is 0).
void checkTetBudget(const TetgenOptions& options, double volume);

// Surface vertex i becomes node i (TetGen keeps input points first), so a render mesh with the
// same vertices follows the body through fem::identityEmbedding(); the other nodes and the tets
// are numbered in Z-order (fem/tet_ordering.h: a cut's tets and a matrix row's nodes lie close
// in memory). Throws std::invalid_argument
// when the surface is not closed, manifold and consistently oriented (mesh::checkMesh), and
// for a self-intersecting surface (found by a TetGen -d pass first: TetGen 1.5 crashes on such
// input otherwise), and std::runtime_error with TetGen's reason when meshing fails.
// `slivers`, when given, receives what the sliver pass did.
mesh::TetMesh tetrahedralize(const mesh::TriMesh& surface, const TetgenOptions& options = {}, SliverStats* slivers = nullptr);

}  // namespace blobvk::fem
