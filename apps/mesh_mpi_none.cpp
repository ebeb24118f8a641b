// mesh_mpi.h in a build without MPI: a job started by mpirun is refused with a clear line.
#include "mesh_mpi.h"

#include <cstdlib>
#include <stdexcept>

namespace blobvk::app {

MpiWorld mpiStart() {
  throw std::runtime_error("started by an MPI launcher, but this blobvk was built without MPI "
                           "(install libopenmpi-dev, reconfigure and rebuild)");
}
void mpiStop() {}
void mpiAbort(const std::string& message) { throw std::runtime_error(message); }
int mpiLayerOwner(int, int) { return 0; }
cpu::MeshLayer mpiLayer(const MpiWorld&, cpu::LayerPolygonizer& layers, int z) { return layers.layer(z); }
void mpiServeLayers(const MpiWorld&, cpu::LayerPolygonizer&) {}

}  // namespace blobvk::app
