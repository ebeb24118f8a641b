// `mpirun -n N blobvk mesh ...`: the streamed job's layers shared out over MPI ranks. Each
// layer has a fixed owner (mpiLayerOwner); a rank computes its layers in order and sends each to
// rank 0 as soon as it is done, without waiting for rank 0 to take it (a few layers in flight);
// rank 0 takes the layers in order, its own or received, and joins them into the file exactly as
// one process would. While the next layer has not arrived, rank 0 computes its own next layers
// ahead instead of waiting. No scheduler of our own: who computes a layer is fixed by its index,
// MPI carries the bytes, and who computes a layer never changes its bytes. Built when CMake
// finds MPI.
#pragma once

#include "blobvk/cpu_simd/streaming_polygonizer.h"

#include <deque>
#include <string>
#include <utility>

namespace blobvk::app {

// True when this process was started by an MPI launcher (mpirun sets OMPI_COMM_WORLD_SIZE,
// PMIX_RANK or PMI_SIZE).
bool launchedByMpi();

struct MpiWorld {
  int rank = 0, size = 1;
  double rootShare = 0.0;  // mpiRootShare, as rank 0 decided it (sent to every rank)
};

// MPI_Init (once), the world's rank and size, and rank 0's share of the layers
// (mpiRootShare). Throws in a build without MPI.
MpiWorld mpiStart(bool rootChecks);
void mpiStop();  // MPI_Finalize, when started
// Ends every rank after an error on one (MPI_Abort), with the message on this rank's stderr.
[[noreturn]] void mpiAbort(const std::string& message);

// The fraction of the layers rank 0 computes besides joining and writing all of them (and,
// when `rootChecks`, checking the mesh as it is written). Joining and writing cost about a tenth
// of computing, the streamed check about a fifth (tower_L6P8I4 at 1024^3, one thread; CPU
// profiles), so with 2 ranks rank 0 takes 0.45 of the layers, 0.25 when it checks; with 3 or
// more, none (its joining is about a share when the others' shares are a third or less).
// BLOBVK_MPI_ROOT_SHARE (0 to 1) overrides it, for clusters where rank 0's host or disk differs
// from the others'; only rank 0's environment counts. Throws std::runtime_error naming the
// variable for a value that is not a number from 0 to 1.
double mpiRootShare(int ranks, bool rootChecks);

// The rank that computes layer z on `ranks` ranks when rank 0 takes `rootShare` of the layers:
// rank 0's layers spread evenly over z, the others round-robin over ranks 1..N-1.
int mpiLayerOwner(int z, int ranks, double rootShare);

// Rank 0's side: the layers in order 0, 1, 2, ..., computed here or received.
class MpiRootLayers {
 public:
  MpiRootLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers);
  cpu::MeshLayer take(int z);  // z must be the previous call's z + 1 (0 first)

 private:
  int owner(int z) const { return mpiLayerOwner(z, world_.size, world_.rootShare); }
  bool computeAhead(int z);  // computes rank 0's next own layer after z, if it may; false if not

  MpiWorld world_;
  cpu::LayerPolygonizer& layers_;
  std::deque<std::pair<int, cpu::MeshLayer>> ahead_;  // own layers computed early, ascending z
  int computedUpTo_ = -1;                             // highest own layer computed so far
};

// Ranks > 0: computes this rank's layers and sends them to rank 0; returns when all are sent.
void mpiServeLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers);

}  // namespace blobvk::app
