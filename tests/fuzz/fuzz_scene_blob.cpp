// Fuzz target: the legacy .blob/.scene reader, then compile() and evaluation.
#include "blobvk/blobtree/scene_blob.h"
#include "blobvk/blobtree/scene_error.h"
#include "fuzz_common.h"

#include <cstdint>
#include <stdexcept>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 16)) return 0;
  try {
    const auto scene = blobvk::blobtree::parseSceneBlob(
        std::string_view(reinterpret_cast<const char*>(data), size), "<fuzz>");
    blobvk::fuzz::compileAndEvaluate(scene.root);
  } catch (const blobvk::blobtree::SceneError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
