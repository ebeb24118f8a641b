// Reader of the thesis' legacy INI-style BlobTree files (.blob, .scene; FileVersion >= 6, also
// the older SkeletonType= files). See docs/scene-format.md, "Legacy .blob files".
#pragma once

#include "blobvk/blobtree/tree.h"

#include <string>
#include <string_view>

namespace blobvk::blobtree {

// Parses legacy text; errors are SceneError with location "line N". NUL bytes are ignored.
// INSTANCE nodes are expanded into copies; NULL primitives (binary-tree padding) are dropped.
Scene parseSceneBlob(std::string_view text, const std::string& sourceName);

// Reads and parses a .blob/.scene file.
Scene readSceneBlob(const std::string& path);

}  // namespace blobvk::blobtree
