#include "blobvk/fem/material.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace blobvk::fem {

void validateMaterial(const Material& m, std::size_t region) {
  const std::string where = "material of region " + std::to_string(region) + ": ";
  if (!(m.youngModulus > 0) || !std::isfinite(m.youngModulus))
    throw std::invalid_argument(where + "Young's modulus E must be > 0 (got " + std::to_string(m.youngModulus) + ")");
  if (!(m.poissonRatio > -1.0 && m.poissonRatio < 0.5))
    throw std::invalid_argument(where + "Poisson ratio nu must lie in (-1, 0.5) (got " +
                                std::to_string(m.poissonRatio) + "); nu >= 0.5 makes lambda infinite");
  if (!(m.density > 0) || !std::isfinite(m.density))
    throw std::invalid_argument(where + "density must be > 0 (got " + std::to_string(m.density) + ")");
}

}  // namespace blobvk::fem
