// MPI ranks for streamed meshing (see mesh_mpi.h). A layer travels as messages tagged with its
// index, in a fixed order: its counts, then each non-empty array straight from the vector that
// holds it (no packing: with shared memory Open MPI copies a large contiguous message once, from
// the sender's memory into the receiver's). The ranks run the same binary on hosts of one byte
// order.
#include "mesh_mpi.h"

#include <mpi.h>

#include <array>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <thread>
#include <vector>

namespace blobvk::app {
namespace {

bool started = false;

// The arrays of a layer in the order they travel; the counts say which are empty.
template <class Layer, class Visit>
void forEachArray(Layer& l, Visit&& visit) {
  visit(l.positions), visit(l.normals), visit(l.colours), visit(l.keys), visit(l.triangles), visit(l.above);
}

std::array<std::uint64_t, 6> countsOf(const cpu::MeshLayer& l) {
  return {std::uint64_t(l.z), l.positions.size(), l.normals.size(), l.colours.size(), l.triangles.size(), l.above.size()};
}

template <class T>
int byteCount(const std::vector<T>& v, int z) {
  if (v.size() * sizeof(T) > std::size_t(INT_MAX))
    throw std::length_error("MPI: an array of layer " + std::to_string(z) + " is over 2 GiB; use a smaller --mpu");
  return int(v.size() * sizeof(T));
}

cpu::MeshLayer receiveLayer(int owner, int z) {
  std::array<std::uint64_t, 6> n{};
  MPI_Recv(n.data(), int(n.size()), MPI_UINT64_T, owner, z, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  const std::uint64_t vertices = n[1];
  if (n[0] != std::uint64_t(z) || (n[2] != 0 && n[2] != vertices) || (n[3] != 0 && n[3] != vertices))
    throw std::runtime_error("MPI: rank " + std::to_string(owner) + " sent inconsistent counts for layer " + std::to_string(z));
  cpu::MeshLayer l;
  l.z = z;
  l.positions.resize(vertices), l.normals.resize(n[2]), l.colours.resize(n[3]), l.keys.resize(vertices);
  l.triangles.resize(n[4]), l.above.resize(n[5]);
  forEachArray(l, [&](auto& v) {
    if (!v.empty()) MPI_Recv(v.data(), byteCount(v, z), MPI_BYTE, owner, z, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  });
  return l;
}

// Waits until `done()` is true, testing it at most every millisecond and sleeping in between.
// MPI's blocking calls spin, which on a machine with more processes than cores (mpirun
// --oversubscribe, or other work beside the job) takes the CPU from the rank being waited for.
// A layer takes tenths of a second to compute, so a millisecond of latency costs nothing.
template <class Done>
void waitSleeping(Done&& done) {
  auto pause = std::chrono::microseconds(50);
  while (!done()) {
    std::this_thread::sleep_for(pause);
    pause = std::min(pause * 2, std::chrono::microseconds(1000));
  }
}

double parseRootShare(const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(v >= 0.0 && v <= 1.0))
    throw std::runtime_error(std::string("BLOBVK_MPI_ROOT_SHARE: expected a number from 0 to 1, got '") + text + "'");
  return v;
}

}  // namespace

double mpiRootShare(int ranks, bool rootChecks) {
  if (const char* text = std::getenv("BLOBVK_MPI_ROOT_SHARE"); text && *text) return parseRootShare(text);
  if (ranks != 2) return 0.0;
  return rootChecks ? 0.25 : 0.45;
}

MpiWorld mpiStart(bool rootChecks) {
  if (!started) {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    started = true;
  }
  MpiWorld w;
  MPI_Comm_rank(MPI_COMM_WORLD, &w.rank);
  MPI_Comm_size(MPI_COMM_WORLD, &w.size);
  // Rank 0 decides the split and tells the others, so that ranks started with different
  // environments still agree on who computes what.
  if (w.rank == 0) {
    try {
      w.rootShare = mpiRootShare(w.size, rootChecks);
    } catch (const std::exception& e) {
      mpiAbort(e.what());
    }
  }
  MPI_Bcast(&w.rootShare, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
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

int mpiLayerOwner(int z, int ranks, double rootShare) {
  if (ranks <= 1) return 0;
  // Rank 0 owns z when the running count floor(z * share) steps up there: its layers are spread
  // evenly, floor(z * share) of them lie below z, and the rest go round the other ranks.
  const auto rootBelow = [rootShare](int k) { return std::int64_t(std::floor(double(k) * rootShare)); };
  if (rootBelow(z + 1) > rootBelow(z)) return 0;
  return 1 + int((std::int64_t(z) - rootBelow(z)) % (ranks - 1));
}

MpiRootLayers::MpiRootLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers)
    : world_(world), layers_(layers) {}

namespace {
// Own layers rank 0 may hold computed ahead of the join: enough to fill the waits for the next
// received layer, few enough to bound the memory (a layer is about 12 MB at 1024^3).
constexpr std::size_t kLayersAhead = 2;
}  // namespace

bool MpiRootLayers::computeAhead(int z) {
  if (ahead_.size() >= kLayersAhead) return false;
  for (int n = std::max(z, computedUpTo_) + 1; n < layers_.layerCount(); ++n)
    if (owner(n) == 0) {
      ahead_.emplace_back(n, layers_.layer(n));
      computedUpTo_ = n;
      return true;
    }
  return false;
}

cpu::MeshLayer MpiRootLayers::take(int z) {
  if (owner(z) == 0) {
    if (!ahead_.empty() && ahead_.front().first == z) {
      cpu::MeshLayer l = std::move(ahead_.front().second);
      ahead_.pop_front();
      return l;
    }
    computedUpTo_ = z;
    return layers_.layer(z);
  }
  // Compute own layers while this one is on its way; take it as soon as its counts are here.
  const auto arrived = [this, z] {
    int flag = 0;
    MPI_Iprobe(owner(z), z, MPI_COMM_WORLD, &flag, MPI_STATUS_IGNORE);
    return flag != 0;
  };
  while (!arrived())
    if (!computeAhead(z)) {
      waitSleeping(arrived);
      break;
    }
  return receiveLayer(owner(z), z);
}

namespace {
// Layers a rank keeps in flight before it waits for rank 0 to take the oldest: enough to run
// ahead of rank 0 while it joins and writes, few enough to bound the memory (a layer is about
// 12 MB at 1024^3, 48 MB at 4096^3).
constexpr std::size_t kLayersInFlight = 4;

struct LayerInFlight {
  cpu::MeshLayer layer;
  std::array<std::uint64_t, 6> counts{};
  std::vector<MPI_Request> requests;
};

void send(LayerInFlight& f) {
  const int z = f.layer.z;
  f.counts = countsOf(f.layer);
  std::vector<std::pair<void*, int>> parts;
  forEachArray(f.layer, [&](auto& v) {
    if (!v.empty()) parts.emplace_back(v.data(), byteCount(v, z));
  });
  f.requests.assign(parts.size() + 1, MPI_REQUEST_NULL);
  MPI_Isend(f.counts.data(), int(f.counts.size()), MPI_UINT64_T, 0, z, MPI_COMM_WORLD, &f.requests[0]);
  for (std::size_t i = 0; i < parts.size(); ++i)
    MPI_Isend(parts[i].first, parts[i].second, MPI_BYTE, 0, z, MPI_COMM_WORLD, &f.requests[i + 1]);
}

bool sent(LayerInFlight& f) {
  int done = 0;
  MPI_Testall(int(f.requests.size()), f.requests.data(), &done, MPI_STATUSES_IGNORE);
  return done != 0;
}

void serveLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers, std::deque<LayerInFlight>& inFlight) {
  auto finishOldest = [&inFlight] {
    waitSleeping([&inFlight] { return sent(inFlight.front()); });
    inFlight.pop_front();
  };
  for (int z = 0; z < layers.layerCount(); ++z) {
    if (mpiLayerOwner(z, world.size, world.rootShare) != world.rank) continue;
    inFlight.push_back(LayerInFlight{layers.layer(z), {}, {}});
    send(inFlight.back());
    // Let the earlier sends progress, and free those rank 0 has taken.
    while (!inFlight.empty() && sent(inFlight.front())) inFlight.pop_front();
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
