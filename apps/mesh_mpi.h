// `mpirun -n N blobvk mesh ...`: the streamed job's layers shared out over MPI ranks, each rank
// writing its own layers into the one file. Each layer has a fixed owner (mpiLayerOwner); a rank
// computes its layers in order and spools their encoded bytes (StreamedMeshFile's sections, its
// own spools), so no layer's bytes travel to another rank. What the ranks exchange is small:
// every layer's vertex and triangle counts (so that each rank knows the global index of every
// layer's first vertex) and, to the owner of the layer below, a layer's bottom plane of vertices
// (keys and positions: the only vertices the layer below refers to, its `above` corners). At the
// end the ranks agree on every layer's place in the file (a sum of the per-layer section sizes),
// and each copies its spooled runs into place in the one shared file while rank 0 writes the
// header. With the streamed check, rank 0 checks the whole mesh in layer order, from its own
// layers and the positions and resolved triangles the other ranks send it. The bytes are the
// one-process file's whoever computes a layer. Built when CMake finds MPI.
#pragma once

#include "resource_limits.h"

#include "blobvk/cpu_simd/streaming_polygonizer.h"
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/streamed_writer.h"

#include <cstdint>
#include <optional>
#include <string>

namespace blobvk::app {

// True when this process was started by an MPI launcher (mpirun sets OMPI_COMM_WORLD_SIZE,
// PMIX_RANK or PMI_SIZE).
bool launchedByMpi();

struct MpiWorld {
  int rank = 0, size = 1;
  double rootShare = 0.0;  // mpiRootShare, as rank 0 decided it (sent to every rank)
  double initSeconds = 0.0;  // this process's MPI_Init (BLOBVK_MPI_TIMES prints it)
};

// MPI_Init (once), the world's rank and size, and rank 0's share of the layers
// (mpiRootShare). Throws in a build without MPI.
MpiWorld mpiStart(bool rootChecks);
void mpiStop();  // MPI_Finalize, when started
// Ends every rank after an error on one (MPI_Abort), with the message on this rank's stderr.
[[noreturn]] void mpiAbort(const std::string& message);

// The fraction of the layers rank 0 computes. Every rank encodes and writes its own layers, so
// without the check the shares are equal (1/N). With it rank 0 also checks every layer, about a
// fifth of computing one (tower_L6P8I4 at 1024^3, one thread; CPU profiles), so it takes
// (1 - 0.2 (N - 1)) / N: 0.4 with 2 ranks, 0.2 with 3, none from 6.
// BLOBVK_MPI_ROOT_SHARE (0 to 1) overrides it, for clusters where rank 0's host differs from the
// others'; only rank 0's environment counts. Throws std::runtime_error naming the variable for a
// value that is not a number from 0 to 1.
double mpiRootShare(int ranks, bool rootChecks);

// The rank that computes layer z on `ranks` ranks when rank 0 takes `rootShare` of the layers:
// rank 0's layers spread evenly over z, the others round-robin over ranks 1..N-1.
int mpiLayerOwner(int z, int ranks, double rootShare);

struct MpiMeshOutput {
  std::string path;  // "-": standard output (through a temporary file beside $TMPDIR)
  mesh::StreamedFileOptions file;
  bool check = false;  // rank 0 runs the streamed check
};

struct MpiMeshResult {  // rank 0's figures; the other ranks' are zero
  std::uint64_t vertices = 0, triangles = 0, bytes = 0;
  std::optional<mesh::MeshReport> report;  // when checked
};

// Every rank of `world` (size > 1): computes its layers, writes them into place and returns once
// the file is complete. Throws (on the rank that failed; the caller aborts the others) on errors,
// and past --max-triangles before anything is written into the file.
MpiMeshResult mpiMeshLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers, const MpiMeshOutput& output,
                            const Limits& limits);

}  // namespace blobvk::app
