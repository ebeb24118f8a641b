// MPI ranks for streamed meshing (see mesh_mpi.h). Every message is one buffer of 64-bit counts
// followed by raw arrays; a receiver takes a sender's messages of one tag in the order they were
// sent (MPI's non-overtaking rule), and the ranks run the same binary on hosts of one byte order.
// Nothing waits in a blocking MPI call: every rank polls and sleeps between polls, because MPI's
// blocking calls spin and, with more processes than cores (mpirun --oversubscribe, or other work
// beside the job), would take the CPU from the rank being waited for.
#include "mesh_mpi.h"

#include "progress.h"

#include "blobvk/mesh/output_place.h"
#include "blobvk/mesh/streamed_check.h"

#include <fcntl.h>
#include <mpi.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

namespace blobvk::app {
namespace {

bool started = false;
double initSeconds = 0.0;

double parseRootShare(const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(v >= 0.0 && v <= 1.0))
    throw std::runtime_error(std::string("BLOBVK_MPI_ROOT_SHARE: expected a number from 0 to 1, got '") + text + "'");
  return v;
}

// Open MPI's default message layer on this Debian build is `cm`, whose MPI_Init probes the
// fabric libraries (libfabric, PSM, PSM2): 0.24-0.31 s per rank, a sixth of a 1024^3 job's time
// on two ranks, for nothing when every rank is on one host, where Open MPI ends up on shared
// memory (ob1) anyway. So when the launcher says all ranks share this host (Open MPI's
// OMPI_COMM_WORLD_LOCAL_SIZE equals OMPI_COMM_WORLD_SIZE) and the user chose no message layer
// (OMPI_MCA_pml unset; `mpirun --mca pml X` sets it), ob1 is asked for before MPI_Init.
// BLOBVK_MPI_PML=keep leaves Open MPI's own choice (for a pml set in an MCA parameter file,
// which the environment would override); auto, the default, is this rule.
void preferSharedMemoryOnOneHost() {
  if (const char* choice = std::getenv("BLOBVK_MPI_PML"); choice && *choice) {
    if (std::strcmp(choice, "keep") == 0) return;
    if (std::strcmp(choice, "auto") != 0)
      throw std::runtime_error(std::string("BLOBVK_MPI_PML: expected 'auto' or 'keep', got '") + choice + "'");
  }
  if (std::getenv("OMPI_MCA_pml")) return;
  const char* size = std::getenv("OMPI_COMM_WORLD_SIZE");
  const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
  if (size && local && *size && std::strcmp(size, local) == 0) setenv("OMPI_MCA_pml", "ob1", 0);
}

}  // namespace

double mpiRootShare(int ranks, bool rootChecks) {
  if (const char* text = std::getenv("BLOBVK_MPI_ROOT_SHARE"); text && *text) return parseRootShare(text);
  if (ranks <= 1) return 1.0;
  const double checkCost = rootChecks ? 0.2 : 0.0;  // of computing a layer
  return std::max(0.0, (1.0 - checkCost * double(ranks - 1)) / double(ranks));
}

MpiWorld mpiStart(bool rootChecks) {
  if (!started) {
    int provided = 0;
    preferSharedMemoryOnOneHost();
    const auto start = std::chrono::steady_clock::now();
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    initSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    started = true;
  }
  MpiWorld w;
  w.initSeconds = initSeconds;
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

namespace {

using Triangle = std::array<std::uint32_t, 3>;

constexpr int kCountsTag = 1;  // {z, vertices, triangles} of a layer, to every other rank
constexpr int kBottomTag = 2;  // {z, n, keys, positions} of a layer's bottom plane, to the owner of the layer below
constexpr int kCheckTag = 3;   // {z, first, n, t, positions, triangles} of a resolved layer, to rank 0 (its check)

// Layers a rank holds computed but not yet written (waiting for another rank's counts or bottom
// plane), and resolved layers' check data rank 0 has not taken yet: enough to run ahead of the
// other ranks, few enough to bound the memory (a layer is about 12 MB at 1024^3).
constexpr std::size_t kLayersHeld = 4;

// One message's bytes: 64-bit counts, then arrays.
class Packet {
 public:
  template <class T>
  void put(const T* data, std::size_t n) {
    if (n == 0) return;
    const std::size_t at = bytes_.size();
    bytes_.resize(at + n * sizeof(T));
    std::memcpy(bytes_.data() + at, static_cast<const void*>(data), n * sizeof(T));
  }
  void word(std::uint64_t w) { put(&w, 1); }
  std::vector<char>& bytes() { return bytes_; }

 private:
  std::vector<char> bytes_;
};

class Unpacker {
 public:
  explicit Unpacker(const std::vector<char>& bytes) : bytes_(bytes) {}
  template <class T>
  void get(T* data, std::size_t n) {
    if (n * sizeof(T) > bytes_.size() - at_) throw std::runtime_error("MPI: a message shorter than its counts say");
    if (n == 0) return;
    std::memcpy(static_cast<void*>(data), bytes_.data() + at_, n * sizeof(T));
    at_ += n * sizeof(T);
  }
  std::uint64_t word() {
    std::uint64_t w = 0;
    get(&w, 1);
    return w;
  }
  template <class T>
  std::vector<T> array(std::uint64_t n) {
    if (n > (bytes_.size() - at_) / sizeof(T)) throw std::runtime_error("MPI: a message shorter than its counts say");
    std::vector<T> v(n);
    get(v.data(), n);
    return v;
  }

 private:
  const std::vector<char>& bytes_;
  std::size_t at_ = 0;
};

int messageBytes(std::size_t n) {
  if (n > std::size_t(INT_MAX)) throw std::length_error("MPI: a layer's message is over 2 GiB; use a smaller --mpu");
  return int(n);
}

// A non-blocking send and the buffer it reads, kept until MPI is done with it.
struct Send {
  std::vector<char> bytes;
  std::vector<MPI_Request> requests;
  bool done() {
    int flag = 0;
    MPI_Testall(int(requests.size()), requests.data(), &flag, MPI_STATUSES_IGNORE);
    return flag != 0;
  }
};

// Seconds a rank spends in each phase, printed on stderr when BLOBVK_MPI_TIMES is set (where
// the time goes when the ranks do not scale).
struct PhaseTimes {
  double compute = 0, spool = 0, check = 0, waiting = 0, place = 0, agree = 0, copy = 0;
  template <class F>
  static auto timed(double& into, F&& f) {
    struct Add {
      double& into;
      std::chrono::steady_clock::time_point start;
      ~Add() { into += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
    } add{into, std::chrono::steady_clock::now()};
    return f();
  }
};

// Sleeps between polls: 50 us at first, doubling up to a millisecond (a layer takes tenths of a
// second to compute, so a millisecond of latency costs nothing).
class Backoff {
 public:
  void wait() {
    std::this_thread::sleep_for(pause_);
    pause_ = std::min(pause_ * 2, std::chrono::microseconds(1000));
  }
  void reset() { pause_ = std::chrono::microseconds(50); }

 private:
  std::chrono::microseconds pause_{50};
};

class LayerJob {
 private:
  struct Pending {  // an own layer computed, its vertices spooled, its triangles not yet
    int z;
    std::vector<mesh::Float3> positions;  // kept for the check or STL facets
    std::vector<Triangle> triangles;
    std::vector<cpu::MeshLayer::AboveCorner> above;
  };
  struct Bottom {  // a layer's bottom plane of vertices (layers_.bottomVertices)
    std::vector<std::uint64_t> keys;
    std::vector<mesh::Float3> positions;
  };
  struct CheckLayer {  // a resolved layer, for rank 0's check
    std::uint64_t first = 0;
    std::vector<mesh::Float3> positions;
    std::vector<Triangle> triangles;
  };

 public:
  LayerJob(const MpiWorld& world, cpu::LayerPolygonizer& layers, const MpiMeshOutput& output)
      : world_(world), layers_(layers), output_(output), L_(layers.layerCount()), file_(output.path, output.file),
        place_(mesh::resolveOutputPlace(output.path)) {
    // The ranks place their parts at offsets in a temporary renamed into place: a device or FIFO
    // (/dev/null, a pipe) cannot be one; "-" is copied out at the end.
    if (output.path != "-" && !place_.replaceByRename)
      throw std::runtime_error(output.path + ": under mpirun the output must be a regular file or a new one, or - (standard output)");
    MPI_Comm_dup(MPI_COMM_WORLD, &comm_);
    MPI_Comm_dup(MPI_COMM_WORLD, &checkComm_);
    S_ = file_.sectionBytes().size();
    sectionLength_.assign(std::size_t(L_) * S_, 0);
    vertices_.assign(std::size_t(L_), -1), triangles_.assign(std::size_t(L_), -1);
    first_.assign(std::size_t(L_) + 1, 0);
    checks_ = output.check && world.rank == 0;
    keepPositions_ = output.check || output.file.format == "stl";  // the check's and STL's facets need them
  }
  ~LayerJob() {
    MPI_Comm_free(&checkComm_);
    MPI_Comm_free(&comm_);
  }

  MpiMeshResult run(const Limits& limits) {
    if (world_.rank == 0) maxTriangles_ = limits.maxTriangles;
    std::optional<Progress> progress;
    if (world_.rank == 0) progress.emplace("mesh", L_);
    std::vector<int> own;
    for (int z = 0; z < L_; ++z)
      if (owner(z) == world_.rank) own.push_back(z);
    Backoff backoff;
    const auto step = [&] {
      bool any = poll();
      any = resolve() || any;
      if (checks_) any = PhaseTimes::timed(times_.check, [&] { return feedCheck(); }) || any;
      any = reapSends() || any;
      if (progress) progress->update(prefix_);
      if (any) backoff.reset();
      return any;
    };
    for (const int z : own) {
      while (mustWait(z))
        if (!step()) PhaseTimes::timed(times_.waiting, [&] { backoff.wait(); });
      compute(z);
      step();
    }
    while (!finished())
      if (!step()) PhaseTimes::timed(times_.waiting, [&] { backoff.wait(); });
    progress.reset();
    MpiMeshResult result = PhaseTimes::timed(times_.place, [&] { return place(limits); });
    if (const char* t = std::getenv("BLOBVK_MPI_TIMES"); t && *t)
      std::fprintf(stderr,
                   "blobvk: rank %d: MPI_Init %.3f s, %zu layers, compute %.3f s, spool %.3f s, check %.3f s, "
                   "waiting %.3f s, placing %.3f s (of which agreeing %.3f s, copying %.3f s)\n",
                   world_.rank, world_.initSeconds, own.size(), times_.compute, times_.spool, times_.check, times_.waiting, times_.place,
                   times_.agree, times_.copy);
    return result;
  }

 private:
  int owner(int z) const { return mpiLayerOwner(z, world_.size, world_.rootShare); }

  // Before computing own layer `next`: hold no more than kLayersHeld layers, unless the oldest
  // waits for `next` itself (its bottom plane), which only this rank can make.
  bool mustWait(int next) {
    if (checkSends_.size() >= kLayersHeld) return true;
    return pending_.size() >= kLayersHeld && pending_.front().z + 1 < next;
  }

  bool finished() const {
    return pending_.empty() && prefix_ == L_ && (!checks_ || checkDone_) && sends_.empty() && checkSends_.empty();
  }

  void record(int z, const std::vector<std::uint64_t>& before) {
    const std::vector<std::uint64_t> after = file_.sectionBytes();
    for (std::size_t s = 0; s < S_; ++s) sectionLength_[std::size_t(z) * S_ + s] += after[s] - before[s];
  }

  void setCounts(int z, std::uint64_t vertices, std::uint64_t triangles) {
    if (z < 0 || z >= L_ || vertices_[std::size_t(z)] >= 0)
      throw std::runtime_error("MPI: counts of layer " + std::to_string(z) + " twice or out of range");
    vertices_[std::size_t(z)] = std::int64_t(vertices), triangles_[std::size_t(z)] = std::int64_t(triangles);
    // --max-triangles as the counts come in (rank 0 hears of every layer): the job stops at the
    // layer that passes the limit, not after the whole grid; the caller aborts every rank.
    countedTriangles_ += triangles;
    if (maxTriangles_ != 0 && countedTriangles_ > maxTriangles_)
      throw std::runtime_error("the mesh has more than --max-triangles " + std::to_string(maxTriangles_) + " triangles (" +
                               std::to_string(countedTriangles_) + " so far); nothing was written");
    while (prefix_ < L_ && vertices_[std::size_t(prefix_)] >= 0) {
      first_[std::size_t(prefix_) + 1] = first_[std::size_t(prefix_)] + std::uint64_t(vertices_[std::size_t(prefix_)]);
      if (first_[std::size_t(prefix_) + 1] >= (1ull << 31))
        throw std::length_error("polygonizeMpuStreamed: more than 2^31 vertices (the mesh's and PLY's index limit)");
      ++prefix_;
    }
  }

  void compute(int z) {
    cpu::MeshLayer l = PhaseTimes::timed(times_.compute, [&] { return layers_.layer(z); });
    {  // counts to every other rank
      Send s;
      Packet p;
      for (std::uint64_t w : {std::uint64_t(z), std::uint64_t(l.positions.size()), std::uint64_t(l.triangles.size())}) p.word(w);
      s.bytes = std::move(p.bytes());
      s.requests.assign(std::size_t(world_.size - 1), MPI_REQUEST_NULL);
      for (int r = 0, i = 0; r < world_.size; ++r)
        if (r != world_.rank)
          MPI_Isend(s.bytes.data(), int(s.bytes.size()), MPI_BYTE, r, kCountsTag, comm_, &s.requests[std::size_t(i++)]);
      sends_.push_back(std::move(s));
    }
    if (z > 0) {  // the bottom plane, to whoever joins the layer below
      const std::size_t n = layers_.bottomVertices(l);
      if (owner(z - 1) == world_.rank) {
        bottoms_[z] = Bottom{{l.keys.begin(), l.keys.begin() + std::ptrdiff_t(n)},
                             {l.positions.begin(), l.positions.begin() + std::ptrdiff_t(n)}};
      } else {
        Packet p;
        p.word(std::uint64_t(z)), p.word(n);
        p.put(l.keys.data(), n), p.put(l.positions.data(), n);
        Send s{std::move(p.bytes()), {MPI_REQUEST_NULL}};
        MPI_Isend(s.bytes.data(), messageBytes(s.bytes.size()), MPI_BYTE, owner(z - 1), kBottomTag, comm_, &s.requests[0]);
        sends_.push_back(std::move(s));
      }
    }
    const std::vector<std::uint64_t> before = file_.sectionBytes();
    PhaseTimes::timed(times_.spool, [&] { file_.vertices(l.positions, l.normals, l.colours); });
    record(z, before);
    setCounts(z, l.positions.size(), l.triangles.size());
    Pending p{z, {}, std::move(l.triangles), std::move(l.above)};
    if (keepPositions_) p.positions = std::move(l.positions);
    pending_.push_back(std::move(p));
  }

  // Counts and bottom planes from the other ranks.
  bool poll() {
    bool any = false;
    for (;;) {
      int flag = 0;
      MPI_Status status;
      MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, comm_, &flag, &status);
      if (!flag) return any;
      any = true;
      int n = 0;
      MPI_Get_count(&status, MPI_BYTE, &n);
      std::vector<char> bytes(std::size_t(std::max(n, 0)));
      MPI_Recv(bytes.data(), n, MPI_BYTE, status.MPI_SOURCE, status.MPI_TAG, comm_, MPI_STATUS_IGNORE);
      Unpacker u(bytes);
      const std::uint64_t z = u.word();
      if (status.MPI_TAG == kCountsTag) {
        const std::uint64_t vertices = u.word();
        setCounts(int(z), vertices, u.word());
      } else if (status.MPI_TAG == kBottomTag) {
        const std::uint64_t count = u.word();
        Bottom b;
        b.keys = u.array<std::uint64_t>(count);
        b.positions = u.array<mesh::Float3>(count);
        bottoms_[int(z)] = std::move(b);
      } else {
        throw std::runtime_error("MPI: a message with an unknown tag");
      }
    }
  }

  // Own layers whose counts below and bottom plane above are here: global corner indices, their
  // triangles encoded into the spools (in layer order, as their vertices were).
  bool resolve() {
    bool any = false;
    while (!pending_.empty()) {
      Pending& p = pending_.front();
      const int z = p.z;
      if (prefix_ <= z) break;  // a lower layer's count is still on its way
      const bool top = z + 1 == L_;
      const auto b = bottoms_.find(z + 1);
      if (!top && b == bottoms_.end()) break;
      const std::uint64_t first = first_[std::size_t(z)], firstAbove = first_[std::size_t(z) + 1];
      for (Triangle& t : p.triangles)
        for (std::uint32_t& v : t) v += std::uint32_t(first);
      for (const cpu::MeshLayer::AboveCorner& c : p.above) {
        if (top) throw std::logic_error("polygonizeMpuStreamed: the top layer refers to a layer above it");
        const std::vector<std::uint64_t>& keys = b->second.keys;
        const auto it = std::lower_bound(keys.begin(), keys.end(), c.key);
        if (it == keys.end() || *it != c.key)
          throw std::logic_error("polygonizeMpuStreamed: a triangle refers to an edge the layer above has no vertex for");
        p.triangles[c.slot / 3][c.slot % 3] = std::uint32_t(firstAbove + std::uint64_t(it - keys.begin()));
      }
      mesh::VertexWindow window;
      window.first = first;
      window.a = p.positions;
      if (!top) window.b = b->second.positions;
      const std::vector<std::uint64_t> before = file_.sectionBytes();
      PhaseTimes::timed(times_.spool, [&] { file_.triangles(p.triangles, window); });
      record(z, before);
      if (output_.check) handOverCheck(z, first, p);
      if (!top) bottoms_.erase(b);
      pending_.pop_front();
      any = true;
    }
    return any;
  }

  // A resolved layer's positions and triangles, to rank 0's check.
  void handOverCheck(int z, std::uint64_t first, Pending& p) {
    if (world_.rank == 0) {
      ownChecks_[z] = CheckLayer{first, std::move(p.positions), std::move(p.triangles)};
      return;
    }
    Packet packet;
    packet.word(std::uint64_t(z)), packet.word(first), packet.word(p.positions.size()), packet.word(p.triangles.size());
    packet.put(p.positions.data(), p.positions.size());
    packet.put(p.triangles.data(), p.triangles.size());
    Send s{std::move(packet.bytes()), {MPI_REQUEST_NULL}};
    MPI_Isend(s.bytes.data(), messageBytes(s.bytes.size()), MPI_BYTE, 0, kCheckTag, checkComm_, &s.requests[0]);
    checkSends_.push_back(std::move(s));
  }

  // Rank 0: the check fed in layer order, as the single process's join feeds it: a layer's
  // vertices, then the triangles of the layer below (whose corners reach into this one).
  bool feedCheck() {
    bool any = false;
    while (nextCheck_ < L_) {
      const int z = nextCheck_;
      CheckLayer current;
      if (owner(z) == 0) {
        const auto it = ownChecks_.find(z);
        if (it == ownChecks_.end()) break;
        current = std::move(it->second);
        ownChecks_.erase(it);
      } else {
        int flag = 0;
        MPI_Status status;
        MPI_Iprobe(owner(z), kCheckTag, checkComm_, &flag, &status);
        if (!flag) break;
        int n = 0;
        MPI_Get_count(&status, MPI_BYTE, &n);
        std::vector<char> bytes(std::size_t(std::max(n, 0)));
        MPI_Recv(bytes.data(), n, MPI_BYTE, owner(z), kCheckTag, checkComm_, MPI_STATUS_IGNORE);
        Unpacker u(bytes);
        if (u.word() != std::uint64_t(z))
          throw std::runtime_error("MPI: rank " + std::to_string(owner(z)) + " sent layers out of order");
        // The first vertex's index travels along: this rank may not have every count below z yet.
        current.first = u.word();
        const std::uint64_t vertices = u.word(), triangles = u.word();
        current.positions = u.array<mesh::Float3>(vertices);
        current.triangles = u.array<Triangle>(triangles);
      }
      check_.vertices(current.positions, {}, {});
      if (previous_) checkLayerBelow(&current);
      previous_ = std::move(current);
      ++nextCheck_;
      any = true;
    }
    if (nextCheck_ == L_ && !checkDone_) {
      if (previous_) checkLayerBelow(nullptr);
      previous_.reset();
      checkDone_ = true;
      any = true;
    }
    return any;
  }

  void checkLayerBelow(const CheckLayer* above) {
    mesh::VertexWindow window;
    window.first = previous_->first;
    window.a = previous_->positions;
    if (above) window.b = above->positions;
    check_.triangles(previous_->triangles, window);
  }

  bool reapSends() {
    bool any = false;
    for (std::deque<Send>* d : {&sends_, &checkSends_})
      while (!d->empty() && d->front().done()) d->pop_front(), any = true;
    return any;
  }

  // Every rank knows every layer's section sizes: each copies its runs to their offsets in one
  // temporary file rank 0 made, rank 0 writes the header and renames the file into place.
  MpiMeshResult place(const Limits& limits) {
    PhaseTimes::timed(times_.agree, [&] {
      MPI_Allreduce(MPI_IN_PLACE, sectionLength_.data(), int(sectionLength_.size()), MPI_UINT64_T, MPI_SUM, comm_);
    });
    MpiMeshResult result;
    result.vertices = first_[std::size_t(L_)];
    for (std::int64_t t : triangles_) result.triangles += std::uint64_t(t);
    if (world_.rank == 0) checkTriangles(result.triangles, limits);  // throws before anything is written
    const std::string head = file_.headerFor(result.vertices, result.triangles);
    std::vector<std::uint64_t> sectionStart(S_ + 1, head.size());
    for (std::size_t s = 0; s < S_; ++s) {
      std::uint64_t total = 0;
      for (int z = 0; z < L_; ++z) total += sectionLength_[std::size_t(z) * S_ + s];
      sectionStart[s + 1] = sectionStart[s] + total;
    }
    result.bytes = sectionStart[S_];
    std::vector<mesh::StreamedMeshFile::Placement> placements;
    for (std::size_t s = 0; s < S_; ++s) {
      std::uint64_t to = sectionStart[s], from = 0;  // in the file; in this rank's spool
      for (int z = 0; z < L_; ++z) {
        const std::uint64_t n = sectionLength_[std::size_t(z) * S_ + s];
        if (owner(z) == world_.rank && n > 0) placements.push_back({int(s), from, n, to}), from += n;
        to += n;
      }
    }

    std::string name;  // rank 0's temporary file, told to every rank
    int fd = -1;
    std::string failure;
    if (world_.rank == 0) {
      try {
        fd = makeTemporary(name);
      } catch (const std::exception& e) {
        failure = e.what();
      }
    }
    std::uint64_t length = name.size();
    MPI_Bcast(&length, 1, MPI_UINT64_T, 0, comm_);
    if (length == 0) throw std::runtime_error(world_.rank == 0 ? failure : "rank 0 could not create the output");
    name.resize(length);
    MPI_Bcast(name.data(), int(length), MPI_CHAR, 0, comm_);
    try {
      if (world_.rank != 0) {
        fd = ::open(name.c_str(), O_WRONLY | O_CLOEXEC);
        if (fd < 0) throw std::runtime_error(name + ": cannot open the output another rank made: " + std::strerror(errno));
      } else {
        mesh::StreamedMeshFile::writeAt(fd, head, 0, output_.path);
      }
      PhaseTimes::timed(times_.copy, [&] { file_.place(fd, placements); });
      if (world_.rank != 0 && ::close(std::exchange(fd, -1)) != 0)
        throw std::runtime_error(output_.path + ": write error: " + std::strerror(errno));
    } catch (const std::exception& e) {
      failure = e.what();
    }
    if (fd >= 0 && world_.rank != 0) ::close(fd);
    int ok = failure.empty() ? 1 : 0;
    MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_MIN, comm_);
    if (world_.rank == 0) {
      if (ok) {
        try {
          finishOutput(fd, name, result.bytes);
        } catch (const std::exception& e) {
          failure = e.what();
        }
      } else {
        if (fd >= 0) ::close(fd);
        ::unlink(name.c_str());
      }
    }
    if (!failure.empty()) throw std::runtime_error(failure);
    if (!ok) throw std::runtime_error("another rank could not write its part of " + output_.path);
    if (checks_) result.report = check_.finish();
    return result;
  }

  std::string outputDirectory() const {
    if (output_.path == "-") {
      const char* tmp = std::getenv("TMPDIR");
      return tmp && *tmp ? tmp : "/tmp";
    }
    return mesh::directoryOf(place_.path);  // beside the file it becomes (a symlink's target)
  }

  int makeTemporary(std::string& name) const {
    name = outputDirectory() + "/.blobvk-out-XXXXXX";
    const int fd = ::mkstemp(name.data());
    if (fd < 0) throw std::runtime_error(outputDirectory() + ": cannot create a temporary file: " + std::strerror(errno));
    return fd;
  }

  // Rank 0, once every rank has placed its runs: the file (`bytes` long) into place, or onto
  // standard output.
  void finishOutput(int fd, const std::string& name, std::uint64_t bytes) {
    try {
      if (output_.path == "-") {
        mesh::StreamedMeshFile::append(fd, STDOUT_FILENO, bytes, "standard output");
        ::close(fd);
        ::unlink(name.c_str());
        return;
      }
      // mkstemp makes 0600; give the file the mode an ordinary create would (0666 less umask).
      const mode_t mask = ::umask(0);
      ::umask(mask);
      ::fchmod(fd, 0666 & ~mask);
      const int closed = ::close(std::exchange(fd, -1));
      if (closed != 0) throw std::runtime_error(output_.path + ": write error: " + std::strerror(errno));
      if (::rename(name.c_str(), place_.path.c_str()) != 0)
        throw std::runtime_error(output_.path + ": cannot write: " + std::strerror(errno));
    } catch (...) {
      if (fd >= 0) ::close(fd);
      ::unlink(name.c_str());
      throw;
    }
  }

  MpiWorld world_;
  cpu::LayerPolygonizer& layers_;
  const MpiMeshOutput& output_;
  const int L_;
  std::size_t S_ = 0;  // sections of the file format
  mesh::StreamedMeshFile file_;  // this rank's spools; never finished, placed instead
  mesh::OutputPlace place_;  // where the file goes: a symlink followed
  MPI_Comm comm_ = MPI_COMM_NULL, checkComm_ = MPI_COMM_NULL;
  bool checks_ = false, keepPositions_ = false;
  PhaseTimes times_;

  std::vector<std::uint64_t> sectionLength_;  // [z * S_ + s]: bytes of layer z in section s
  std::vector<std::int64_t> vertices_, triangles_;  // per layer; -1 until known
  std::vector<std::uint64_t> first_;  // global index of each layer's first vertex, for z <= prefix_
  int prefix_ = 0;                    // the counts of layers below prefix_ are known
  std::uint64_t maxTriangles_ = 0;      // rank 0: --max-triangles (0: none)
  std::uint64_t countedTriangles_ = 0;  // the triangles of the layers whose counts are known
  std::deque<Pending> pending_;
  std::map<int, Bottom> bottoms_;
  std::deque<Send> sends_, checkSends_;

  mesh::StreamedMeshCheck check_;  // rank 0, when checking
  std::map<int, CheckLayer> ownChecks_;
  std::optional<CheckLayer> previous_;
  int nextCheck_ = 0;
  bool checkDone_ = false;
};

}  // namespace

MpiMeshResult mpiMeshLayers(const MpiWorld& world, cpu::LayerPolygonizer& layers, const MpiMeshOutput& output,
                            const Limits& limits) {
  LayerJob job(world, layers, output);
  return job.run(limits);
}

}  // namespace blobvk::app
