#include "blobvk/surgery/tissue_regions.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/fem/tet_utils.h"

#include <glm/vec3.hpp>

#include <stdexcept>

namespace blobvk::surgery {

std::uint32_t dominantPrimitive(const blobtree::Program& program, const mesh::Double3& c) {
  if (program.primitives.empty()) throw std::invalid_argument("dominantPrimitive: the model has no primitives");
  const glm::vec3 p(float(c.x), float(c.y), float(c.z));
  std::uint32_t best = 0;
  float bestField = -1.0f;
  for (std::uint32_t i = 0; i < program.primitives.size(); ++i) {
    const float f = blobtree::primitiveField(program, program.primitives[i], p);
    if (f > bestField) {
      bestField = f;
      best = i;
    }
  }
  return best;
}

void assignTissueRegions(const blobtree::Program& program, mesh::TetMesh& tets) {
  fem::assignRegions(tets, [&program](const mesh::Double3& c) { return dominantPrimitive(program, c); });
}

}  // namespace blobvk::surgery
