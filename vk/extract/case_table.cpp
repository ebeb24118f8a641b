#include "blobvk/vk/extract/case_table.h"

#include "blobvk/mesh/marching_cubes.h"

namespace blobvk::vk {

const std::vector<std::uint32_t>& packedCaseTable() {
  static const std::vector<std::uint32_t> words = [] {
    std::vector<std::uint32_t> w(256 * 20, 0);
    const auto& cases = mesh::marchingCubesCases();
    for (std::size_t c = 0; c < 256; ++c) {
      w[c * 20] = cases[c].triangleCount;
      for (std::size_t e = 0; e < 18; ++e) w[c * 20 + 1 + e] = cases[c].edges[e];
    }
    return w;
  }();
  return words;
}

const std::vector<std::uint32_t>& caseTableUniform() {
  static const std::vector<std::uint32_t> words = [] {
    std::vector<std::uint32_t> w(256 * 4, 0);
    const auto& cases = mesh::marchingCubesCases();
    for (std::size_t c = 0; c < 256; ++c) {
      w[c * 4] = cases[c].triangleCount;
      for (std::size_t e = 0; e < 3u * cases[c].triangleCount; ++e) {
        w[c * 4 + 1 + e / 8] |= std::uint32_t(cases[c].edges[e]) << (4 * (e % 8));
      }
    }
    return w;
  }();
  return words;
}

}  // namespace blobvk::vk
