// Fuzz target: the JSON scene reader, then compile() and evaluation of whatever it accepts.
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_json.h"
#include "fuzz_common.h"

#include <cstdint>
#include <stdexcept>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 16)) return 0;  // large inputs only slow the search down
  try {
    const auto scene = blobvk::blobtree::parseSceneJson(
        std::string_view(reinterpret_cast<const char*>(data), size), "<fuzz>");
    blobvk::fuzz::compileAndEvaluate(scene.root);
  } catch (const blobvk::blobtree::SceneError&) {
  } catch (const std::invalid_argument&) {  // compile() refusing a tree (nesting, registers)
  }
  return 0;
}
