// OP_POW's float semantics, the same on every backend: pow(max(base, 0), e) for e > 0, and a
// result below the smallest normal float flushed to +0. GPUs may flush denormals (llvmpipe does),
// so a CPU that kept them would disagree with them wherever a Ricci blend's children are small:
// at power 16, the field below 2^(-126/16) (0.0043) differed by up to 0.004 between the two.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace blobvk::blobtree {

inline float powField(float base, float exponent) {
  const float r = std::pow(std::max(base, 0.0f), exponent);
  return r < std::numeric_limits<float>::min() ? 0.0f : r;
}

// An interval of OP_POW's values over [lo, hi] (doubles, e > 0) that holds powField's float
// results: the double results, each end flushed as powField flushes, and +inf past the largest
// float (where the float pow overflows).
inline void powFieldBounds(double& lo, double& hi, double exponent) {
  const auto flushed = [](double v) {
    if (v < double(std::numeric_limits<float>::min())) return 0.0;
    if (v > double(std::numeric_limits<float>::max())) return std::numeric_limits<double>::infinity();
    return v;
  };
  lo = flushed(std::pow(std::max(lo, 0.0), exponent));
  hi = flushed(std::pow(std::max(hi, 0.0), exponent));
}

}  // namespace blobvk::blobtree
