// Format-independent scene loading and saving, picked by file extension.
#pragma once

#include "blobvk/blobtree/tree.h"

#include <string>

namespace blobvk::blobtree {

// .json -> JSON format; .blob, .scene -> legacy format (case-insensitive extensions).
// Throws SceneError for unknown extensions, unreadable files and invalid content.
Scene loadScene(const std::string& path);

// Writes the JSON format; throws SceneError when the file cannot be written.
void saveSceneJson(const Scene& scene, const std::string& path);

}  // namespace blobvk::blobtree
