// The parts of the TetGen front end that do not need TetGen itself (always compiled).
#include "blobvk/fem/tetgen_mesher.h"

#include <cstdio>
#include <stdexcept>

namespace blobvk::fem {

std::string tetgenSwitches(const TetgenOptions& o) {
  std::string s = "pzQ";
  char buf[96];
  if (o.quality) {
    if (o.maxRadiusEdgeRatio < 1.0) throw std::invalid_argument("TetGen: radius-edge bound must be >= 1.0");
    if (o.minDihedralDegrees > 0)
      std::snprintf(buf, sizeof buf, "q%.6g/%.6g", o.maxRadiusEdgeRatio, o.minDihedralDegrees);
    else
      std::snprintf(buf, sizeof buf, "q%.6g", o.maxRadiusEdgeRatio);
    s += buf;
  }
  if (o.maxVolume > 0) {
    std::snprintf(buf, sizeof buf, "a%.9g", o.maxVolume);
    s += buf;
  }
  if (o.maxAddedPoints > 0) {
    // TetGen reads the number into an int: a larger one would wrap negative and mean no limit.
    if (o.maxAddedPoints > 2147483647u) throw std::invalid_argument("TetGen: at most 2147483647 added points");
    std::snprintf(buf, sizeof buf, "S%u", unsigned(o.maxAddedPoints));
    s += buf;
  }
  if (o.keepSurface) s += "Y";
  if (o.optimizeMaxDihedralDegrees > 0) {
    if (o.optimizeMaxDihedralDegrees >= 180) throw std::invalid_argument("TetGen: the optimization dihedral bound must be < 180 degrees");
    std::snprintf(buf, sizeof buf, "o/%.6g", o.optimizeMaxDihedralDegrees);
    s += buf;
  }
  return s;
}

void checkTetBudget(const TetgenOptions& o, double volume) {
  if (o.maxVolume <= 0 || o.maxAddedPoints == 0) return;
  const double asked = volume / o.maxVolume, allowed = 6.0 * double(o.maxAddedPoints);
  if (asked > allowed) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "tetrahedralize: a largest tet volume of %.6g asks for about %.3g tets in a body of volume %.6g, "
                  "over the limit of about %.3g (6 per added point, at most %u points)",
                  o.maxVolume, asked, volume, allowed, unsigned(o.maxAddedPoints));
    throw std::invalid_argument(buf);
  }
}

#if !BLOBVK_HAS_TETGEN
bool tetgenAvailable() { return false; }
mesh::TetMesh tetrahedralize(const mesh::TriMesh&, const TetgenOptions&, SliverStats*) {
  throw std::runtime_error("blobvk was built without TetGen (BLOBVK_WITH_TETGEN=OFF); use the voxel mesher");
}
#endif

}  // namespace blobvk::fem
