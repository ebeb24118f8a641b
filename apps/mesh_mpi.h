// `mpirun -n N blobvk mesh ...`: the streamed job's layers shared out over MPI ranks. Each
// layer has a fixed owner (mpiLayerOwner); a rank computes its layers in order and sends each to
// rank 0 as soon as it is done, without waiting for rank 0 to take it (a few layers in flight);
// rank 0 computes its own, receives the others in layer order and joins them into the file
// exactly as one process would. No scheduler of our own: the split is fixed by the layer index
// and MPI carries the bytes. Built when CMake finds MPI.
#pragma once

#include "blobvk/cpu_simd/streaming_polygonizer.h"

#include <string>

namespace blobvk::app {

// True when this process was started by an MPI launcher (mpirun sets OMPI_COMM_WORLD_SIZE,
// PMIX_RANK or PMI_SIZE).
bool launchedByMpi();

struct MpiWorld {
  int rank = 0, size = 1;
};

// MPI_Init (once) and the world's rank and size. Throws in a build without MPI.
MpiWorld mpiStart();
void mpiStop();  // MPI_Finalize, when started
// Ends every rank after an error on one (MPI_Abort), with the message on this rank's stderr.
[[noreturn]] void mpiAbort(const std::string& message);

// The rank that computes layer z of a job on `ranks` ranks. Rank 0 also joins and writes every
// layer, which costs about half as much as computing them all (1024^3 tower_L6P8I4, one thread:
// 8.5 s computing, about 4 s joining, writing and spooling), so it owns a smaller share: with 2
// ranks one layer in 4, with 3 or more none (its joining alone is about a share), the others
// round-robin over ranks 1..N-1. Who computes a layer never changes its bytes.
int mpiLayerOwner(int z, int ranks);

// Rank 0: layer z, computed here or received from the rank that owns it. Layers must be asked
// for in order 0, 1, 2, ...
cpu::MeshLayer mpiLayer(const MpiWorld& world, cpu::LayerPolygonizer& layers, int z);
// Ranks > 0: computes this rank's layers and sends them to rank 0; returns when all are sent.
void mpiServeLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers);

}  // namespace blobvk::app
