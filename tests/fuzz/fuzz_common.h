// Shared by the fuzz targets: what an input may do is throw the library's documented
// exceptions; anything else (a crash, a sanitizer report, another exception type) is a finding.
#pragma once

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"

#include <cmath>
#include <cstdlib>

namespace blobvk::fuzz {

// Compiles a parsed tree and evaluates it at a few points; the field must be a number.
inline void compileAndEvaluate(const blobtree::Node& root) {
  const blobtree::Program program = blobtree::compile(root);
  const glm::vec3 points[] = {{0, 0, 0}, {0.3f, -0.2f, 0.1f}, {2, 1, -1}, {-5, 4, 3}};
  for (const glm::vec3& p : points) {
    const float f = blobtree::evaluate(program, p);
    if (std::isnan(f)) std::abort();  // finite inputs must give a finite field
  }
}

}  // namespace blobvk::fuzz
