// The only file that includes TetGen (AGPL-3.0+). Compiled only with BLOBVK_WITH_TETGEN=ON.
#include "blobvk/fem/tetgen_mesher.h"

#include "blobvk/fem/tet_ordering.h"
#include "blobvk/fem/tet_utils.h"
#include "blobvk/mesh/checks.h"

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

  tetgenio in, out;
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
  std::string switches = tetgenSwitches(options);
  try {
    ::tetrahedralize(switches.data(), &in, &out);
  } catch (int code) {
    throw std::runtime_error("TetGen (switches " + switches + ") failed: " + tetgenReason(code));
  }
  if (out.numberoftetrahedra <= 0 || out.numberofcorners < 4)
    throw std::runtime_error("TetGen produced no tetrahedra");

  mesh::TetMesh mesh;
  mesh.positions.resize(std::size_t(out.numberofpoints));
  for (int i = 0; i < out.numberofpoints; ++i)
    mesh.positions[std::size_t(i)] = {out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2]};
  mesh.restPositions = mesh.positions;
  mesh.tets.resize(std::size_t(out.numberoftetrahedra));
  for (int t = 0; t < out.numberoftetrahedra; ++t)
    for (int k = 0; k < 4; ++k)
      mesh.tets[std::size_t(t)][std::size_t(k)] = std::uint32_t(out.tetrahedronlist[t * out.numberofcorners + k]);
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
