// The only file that includes TetGen (AGPL-3.0+). Compiled only with BLOBVK_WITH_TETGEN=ON.
#include "blobvk/fem/tetgen_mesher.h"

#include "blobvk/fem/tet_ordering.h"
#include "blobvk/fem/tet_utils.h"
#include "blobvk/mesh/checks.h"

#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#define TETLIBRARY
#include <tetgen.h>

namespace blobvk::fem {
namespace {

std::string tetgenReason(int code) {
  switch (code) {
    case 1: return "out of memory";
    case 2: return "internal error";
    case 3: return "the surface intersects itself";
    case 4: return "a very small input feature was detected (degenerate or nearly touching triangles)";
    case 5: return "two very close input facets were detected";
    case 10: return "input error";
    default: return "error code " + std::to_string(code);
  }
}

// What a TetGen run gives back: 3 coordinates per point, 4 corners per tet.
struct TetgenOutput {
  std::vector<double> points;
  std::vector<int> tets;
};

// Both TetGen passes, in this process; throws as tetrahedralize() documents.
TetgenOutput runTetgen(tetgenio& in, std::string switches) {
  // TetGen 1.5 segfaults on self-intersecting input instead of reporting it (measured), so a
  // detection-only pass (-d) runs first: it lists the intersecting facets and builds no tets.
  {
    tetgenio check;
    char detect[] = "pzdQ";
    try {
      ::tetrahedralize(detect, &in, &check);
    } catch (int code) {
      throw std::runtime_error("TetGen self-intersection check failed: " + tetgenReason(code));
    }
    if (check.numberoftrifaces > 0)
      throw std::invalid_argument("tetrahedralize: the surface intersects itself (" + std::to_string(check.numberoftrifaces) +
                                  " intersecting triangles)");
  }
  tetgenio out;
  try {
    ::tetrahedralize(switches.data(), &in, &out);
  } catch (int code) {
    throw std::runtime_error("TetGen (switches " + switches + ") failed: " + tetgenReason(code));
  }
  if (out.numberoftetrahedra <= 0 || out.numberofcorners < 4) throw std::runtime_error("TetGen produced no tetrahedra");
  TetgenOutput result;
  result.points.assign(out.pointlist, out.pointlist + 3 * std::size_t(out.numberofpoints));
  result.tets.resize(4 * std::size_t(out.numberoftetrahedra));
  for (std::size_t t = 0; t < std::size_t(out.numberoftetrahedra); ++t)
    for (std::size_t k = 0; k < 4; ++k) result.tets[4 * t + k] = out.tetrahedronlist[t * std::size_t(out.numberofcorners) + k];
  return result;
}

bool writeAll(int fd, const void* data, std::size_t bytes) {
  const char* p = static_cast<const char*>(data);
  while (bytes > 0) {
    const ssize_t n = ::write(fd, p, bytes);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    bytes -= std::size_t(n);
  }
  return true;
}

// TetGen still crashes in its own clean-up on some valid closed surfaces (measured: the
// clean-up's surface of scenes/eggshell_sim.json at 24 cells, 35 pieces, segfaults in
// memorypool::~memorypool), and a library must not take its host down: the run happens in a
// child process, which sends back its result (or its exception's kind and message) through a
// pipe; a child killed by a signal becomes a std::runtime_error. The child only runs TetGen
// (single-threaded) and leaves with _exit, so nothing of the parent's state runs twice.
TetgenOutput runIsolated(const std::function<TetgenOutput()>& run) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error(std::string("tetrahedralize: pipe: ") + std::strerror(errno));
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t parent = ::getpid();
  const pid_t child = ::fork();
  if (child < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error(std::string("tetrahedralize: fork: ") + std::strerror(errno));
  }
  if (child == 0) {
    // A host killed while TetGen runs takes its child along (a job runner's kill of the host
    // left TetGen computing as an orphan). The forking thread waits in waitpid until the child
    // ends, so the death signal, sent when that thread ends, means the host is gone. A host that
    // died before the prctl is caught by getppid.
    if (::prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || ::getppid() != parent) ::_exit(1);
    ::close(fds[0]);
    char kind = 0;  // 0: result, 1: std::invalid_argument, 2: another exception
    std::string message;
    TetgenOutput out;
    try {
      out = run();
    } catch (const std::invalid_argument& e) {
      kind = 1;
      message = e.what();
    } catch (const std::exception& e) {
      kind = 2;
      message = e.what();
    }
    const std::uint64_t sizes[3] = {out.points.size(), out.tets.size(), message.size()};
    const bool ok = writeAll(fds[1], &kind, 1) && writeAll(fds[1], sizes, sizeof sizes) &&
                    writeAll(fds[1], out.points.data(), out.points.size() * sizeof(double)) &&
                    writeAll(fds[1], out.tets.data(), out.tets.size() * sizeof(int)) &&
                    writeAll(fds[1], message.data(), message.size());
    ::_exit(ok ? 0 : 1);
  }
  ::close(fds[1]);
  std::string bytes;  // read to the end before waiting: the child blocks on a full pipe
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    bytes.append(buffer, std::size_t(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status))
    throw std::runtime_error(std::string("TetGen crashed on this surface (") + strsignal(WTERMSIG(status)) + ")");
  std::uint64_t sizes[3] = {};
  // A sanitizer's or a handler's exit after a crash reads as an exit without a whole result.
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.size() < 1 + sizeof sizes)
    throw std::runtime_error("TetGen crashed on this surface (its process exited with status " +
                             std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + " without a result)");
  std::memcpy(sizes, bytes.data() + 1, sizeof sizes);
  const std::size_t expected = 1 + sizeof sizes + sizes[0] * sizeof(double) + sizes[1] * sizeof(int) + sizes[2];
  if (bytes.size() != expected) throw std::runtime_error("TetGen's process sent a truncated result");
  const char* at = bytes.data() + 1 + sizeof sizes;
  TetgenOutput out;
  out.points.resize(sizes[0]);
  if (sizes[0] > 0) std::memcpy(out.points.data(), at, sizes[0] * sizeof(double));
  at += sizes[0] * sizeof(double);
  out.tets.resize(sizes[1]);
  if (sizes[1] > 0) std::memcpy(out.tets.data(), at, sizes[1] * sizeof(int));
  at += sizes[1] * sizeof(int);
  const std::string message(at, sizes[2]);
  if (bytes[0] == 1) throw std::invalid_argument(message);
  if (bytes[0] == 2) throw std::runtime_error(message);
  return out;
}

}  // namespace

bool tetgenAvailable() { return true; }

mesh::TetMesh tetrahedralize(const mesh::TriMesh& surface, const TetgenOptions& options, SliverStats* slivers) {
  const mesh::MeshReport report = mesh::checkMesh(surface);
  if (surface.triangles.empty()) throw std::invalid_argument("tetrahedralize: the surface has no triangles");
  if (!report.watertight())
    throw std::invalid_argument("tetrahedralize: the surface must be closed, manifold and consistently oriented (" +
                                report.summary() + ")");
  if (!(report.volume > 0))
    throw std::invalid_argument("tetrahedralize: the surface encloses no positive volume (inside out?)");
  checkTetBudget(options, report.volume);

  tetgenio in;
  in.firstnumber = 0;
  in.numberofpoints = int(surface.positions.size());
  in.pointlist = new REAL[surface.positions.size() * 3];
  for (std::size_t i = 0; i < surface.positions.size(); ++i) {
    in.pointlist[3 * i + 0] = surface.positions[i].x;
    in.pointlist[3 * i + 1] = surface.positions[i].y;
    in.pointlist[3 * i + 2] = surface.positions[i].z;
  }
  in.numberoffacets = int(surface.triangles.size());
  in.facetlist = new tetgenio::facet[surface.triangles.size()];
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    tetgenio::facet& facet = in.facetlist[f];
    tetgenio::init(&facet);
    facet.numberofpolygons = 1;
    facet.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&facet.polygonlist[0]);
    facet.polygonlist[0].numberofvertices = 3;
    facet.polygonlist[0].vertexlist = new int[3];
    for (int k = 0; k < 3; ++k) facet.polygonlist[0].vertexlist[k] = int(surface.triangles[f][k]);
  }

  if (!options.holes.empty()) {
    in.numberofholes = int(options.holes.size());
    in.holelist = new REAL[options.holes.size() * 3];
    for (std::size_t i = 0; i < options.holes.size(); ++i) {
      in.holelist[3 * i + 0] = options.holes[i].x;
      in.holelist[3 * i + 1] = options.holes[i].y;
      in.holelist[3 * i + 2] = options.holes[i].z;
    }
  }

  const std::string switches = tetgenSwitches(options);
  const TetgenOutput out = options.isolateInChildProcess ? runIsolated([&] { return runTetgen(in, switches); })
                                                         : runTetgen(in, switches);
  mesh::TetMesh mesh;
  mesh.positions.resize(out.points.size() / 3);
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    mesh.positions[i] = {out.points[3 * i], out.points[3 * i + 1], out.points[3 * i + 2]};
  mesh.restPositions = mesh.positions;
  mesh.tets.resize(out.tets.size() / 4);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (std::size_t k = 0; k < 4; ++k) mesh.tets[t][k] = std::uint32_t(out.tets[4 * t + k]);
  orientTets(mesh);
  // Before the sliver pass, so that the numbering is TetGen's mesh's whatever that pass moves.
  orderForLocality(mesh, surface.positions.size());
  if (options.quality && options.smoothSlivers && options.minDihedralDegrees > 0) {
    const SliverStats stats = smoothSlivers(mesh, options.minDihedralDegrees, surface.positions.size());
    if (slivers) *slivers = stats;
  }
  return mesh;
}

}  // namespace blobvk::fem
