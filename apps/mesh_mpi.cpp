// MPI ranks for streamed meshing (see mesh_mpi.h). A layer travels as one message of bytes
// tagged with its index: a small header of counts, then the arrays as they lie in memory (the
// ranks run the same binary on hosts of one byte order).
#include "mesh_mpi.h"

#include <mpi.h>

#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <stdexcept>
#include <vector>

namespace blobvk::app {
namespace {

bool started = false;

template <class T>
void put(std::vector<char>& out, const std::vector<T>& v) {
  const char* p = reinterpret_cast<const char*>(v.data());
  out.insert(out.end(), p, p + v.size() * sizeof(T));
}

template <class T>
void take(const char*& p, const char* end, std::vector<T>& v, std::uint64_t n) {
  if (std::uint64_t(end - p) < n * sizeof(T)) throw std::runtime_error("MPI: a layer message is shorter than its counts");
  v.resize(n);
  std::memcpy(v.data(), p, n * sizeof(T));
  p += n * sizeof(T);
}

std::vector<char> encode(const cpu::MeshLayer& l) {
  const std::uint64_t head[6] = {std::uint64_t(l.z), l.positions.size(), l.normals.size(), l.colours.size(),
                                 l.triangles.size(), l.above.size()};
  std::vector<char> out(reinterpret_cast<const char*>(head), reinterpret_cast<const char*>(head) + sizeof head);
  put(out, l.positions), put(out, l.normals), put(out, l.colours), put(out, l.keys);
  put(out, l.triangles), put(out, l.above);
  return out;
}

cpu::MeshLayer decode(const std::vector<char>& bytes) {
  std::uint64_t head[6];
  if (bytes.size() < sizeof head) throw std::runtime_error("MPI: a layer message without its header");
  std::memcpy(head, bytes.data(), sizeof head);
  const char* p = bytes.data() + sizeof head;
  const char* end = bytes.data() + bytes.size();
  cpu::MeshLayer l;
  l.z = int(head[0]);
  take(p, end, l.positions, head[1]), take(p, end, l.normals, head[2]), take(p, end, l.colours, head[3]);
  take(p, end, l.keys, head[1]), take(p, end, l.triangles, head[4]), take(p, end, l.above, head[5]);
  if (p != end) throw std::runtime_error("MPI: a layer message is longer than its counts");
  return l;
}

}  // namespace

MpiWorld mpiStart() {
  if (!started) {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    started = true;
  }
  MpiWorld w;
  MPI_Comm_rank(MPI_COMM_WORLD, &w.rank);
  MPI_Comm_size(MPI_COMM_WORLD, &w.size);
  return w;
}

void mpiStop() {
  if (started) MPI_Finalize();
  started = false;
}

void mpiAbort(const std::string& message) {
  std::fprintf(stderr, "blobvk: error: %s\n", message.c_str());
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::exit(1);
}

int mpiLayerOwner(int z, int ranks) {
  if (ranks <= 1) return 0;
  if (ranks >= 3) return 1 + z % (ranks - 1);  // rank 0's joining is a full share already
  return z % 4 == 0 ? 0 : 1;
}

cpu::MeshLayer mpiLayer(const MpiWorld& world, cpu::LayerPolygonizer& layers, int z) {
  const int owner = mpiLayerOwner(z, world.size);
  if (owner == 0) return layers.layer(z);
  MPI_Status status;
  MPI_Probe(owner, z, MPI_COMM_WORLD, &status);
  int count = 0;
  MPI_Get_count(&status, MPI_BYTE, &count);
  std::vector<char> bytes(std::size_t(count > 0 ? count : 0));
  MPI_Recv(bytes.data(), count, MPI_BYTE, owner, z, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return decode(bytes);
}

namespace {
// Layers a rank keeps in flight before it waits for rank 0 to take the oldest: enough to run
// ahead of rank 0 while it joins and writes, few enough to bound the memory (a layer's message is
// about 12 MB at 1024^3, 48 MB at 4096^3).
constexpr std::size_t kLayersInFlight = 4;

struct LayerInFlight {
  std::vector<char> bytes;
  MPI_Request request = MPI_REQUEST_NULL;
};

void serveLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers, std::deque<LayerInFlight>& inFlight) {
  auto finishOldest = [&inFlight] {
    MPI_Wait(&inFlight.front().request, MPI_STATUS_IGNORE);
    inFlight.pop_front();
  };
  for (int z = 0; z < layers.layerCount(); ++z) {
    if (mpiLayerOwner(z, world.size) != world.rank) continue;
    LayerInFlight sent{encode(layers.layer(z)), MPI_REQUEST_NULL};
    if (sent.bytes.size() > std::size_t(INT_MAX))
      throw std::length_error("MPI: layer " + std::to_string(z) + " is over 2 GiB; use a smaller --mpu");
    inFlight.push_back(std::move(sent));
    MPI_Isend(inFlight.back().bytes.data(), int(inFlight.back().bytes.size()), MPI_BYTE, 0, z, MPI_COMM_WORLD,
              &inFlight.back().request);
    // Let the earlier sends progress, and free those rank 0 has taken.
    while (!inFlight.empty()) {
      int done = 0;
      MPI_Test(&inFlight.front().request, &done, MPI_STATUS_IGNORE);
      if (!done) break;
      inFlight.pop_front();
    }
    while (inFlight.size() > kLayersInFlight) finishOldest();
  }
  while (!inFlight.empty()) finishOldest();
}
}  // namespace

// Non-blocking sends, so that a rank computes its next layer while rank 0 is still joining the
// previous ones. With shared memory (Open MPI's vader and its single-copy CMA) rank 0 pulls a
// large message itself once it asks for it; elsewhere the transfer moves on each time this rank
// enters MPI, i.e. after each layer it computes.
void mpiServeLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers) {
  std::deque<LayerInFlight> inFlight;
  try {
    serveLayers(world, layers, inFlight);
  } catch (const std::exception& e) {
    // Abort while the buffers of the sends in flight still exist: rank 0 may be reading them.
    mpiAbort(e.what());
  }
}
}  // namespace blobvk::app
