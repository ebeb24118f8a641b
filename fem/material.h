// Linear-elastic material of one region of a tet mesh, and its validation.
#pragma once

#include <cstddef>

namespace blobvk::fem {

struct Material {
  double youngModulus = 1.0e5;  // E in Pa, > 0
  double poissonRatio = 0.45;   // nu in (-1, 0.5): 0.5 would be incompressible (infinite lambda)
  double density = 1000.0;      // kg/m^3, > 0

  // Lame parameters used by the element kernel.
  double lambda() const { return youngModulus * poissonRatio / ((1 + poissonRatio) * (1 - 2 * poissonRatio)); }
  double mu() const { return youngModulus / (2 * (1 + poissonRatio)); }
};

// Throws std::invalid_argument naming the region when E <= 0, nu outside (-1, 0.5) or density <= 0.
void validateMaterial(const Material& material, std::size_t region);

}  // namespace blobvk::fem
