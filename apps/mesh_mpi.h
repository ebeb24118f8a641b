// `mpirun -n N blobvk mesh ...`: the streamed job's layers shared out over MPI ranks. Rank r
// computes the layers z with z % N == r and sends each to rank 0 (a blocking send: a rank
// holds one layer); rank 0 computes its own, receives the others in layer order and
// joins them into the file exactly as one process would. No scheduler of our own: the split is
// fixed by the layer index and MPI carries the bytes. Built when CMake finds MPI.
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

// Rank 0: layer z, computed here or received from the rank that owns it. Layers must be asked
// for in order 0, 1, 2, ...
cpu::MeshLayer mpiLayer(const MpiWorld& world, cpu::LayerPolygonizer& layers, int z);
// Ranks > 0: computes this rank's layers and sends them to rank 0; returns when all are sent.
void mpiServeLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers);

}  // namespace blobvk::app
