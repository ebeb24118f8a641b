// mesh_mpi.h in a build without MPI: a job started by mpirun is refused with a clear line.
#include "mesh_mpi.h"

#include <cstdlib>
#include <stdexcept>

namespace blobvk::app {

MpiWorld mpiStart(bool) {
  throw std::runtime_error("started by an MPI launcher, but this blobvk was built without MPI "
                           "(install libopenmpi-dev, reconfigure and rebuild)");
}
void mpiStop() {}
void mpiAbort(const std::string& message) { throw std::runtime_error(message); }
double mpiRootShare(int, bool) { return 1.0; }
int mpiLayerOwner(int, int, double) { return 0; }
MpiMeshResult mpiMeshLayers(const MpiWorld&, cpu::LayerPolygonizer&, const MpiMeshOutput&, const Limits&) {
  throw std::logic_error("mpiMeshLayers: this blobvk was built without MPI");
}

}  // namespace blobvk::app
