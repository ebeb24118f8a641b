#include "blobvk/blobtree/scene_io.h"

#include "blobvk/blobtree/scene_blob.h"
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_json.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace blobvk::blobtree {

Scene loadScene(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw SceneError(path, "", "is a directory, not a scene file");
  if (ext == ".json") return readSceneJson(path);
  if (ext == ".blob" || ext == ".scene") return readSceneBlob(path);
  throw SceneError(path, "", "unknown scene extension '" + ext + "' (expected .json, .blob or .scene)");
}

void saveSceneJson(const Scene& scene, const std::string& path) {
  const std::string text = writeSceneJson(scene);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw SceneError(path, "cannot write", std::strerror(errno));
  out << text;
  out.close();
  if (!out) throw SceneError(path, "write error", std::strerror(errno));
}

}  // namespace blobvk::blobtree
