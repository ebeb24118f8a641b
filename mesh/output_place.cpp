#include "blobvk/mesh/output_place.h"

#include <filesystem>

namespace blobvk::mesh {

OutputPlace resolveOutputPlace(const std::string& path) {
  namespace fs = std::filesystem;
  OutputPlace place{path, true};
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(path, ec))) {
    // weakly_canonical follows every link, also to a target that does not exist yet.
    const fs::path target = fs::weakly_canonical(path, ec);
    if (!ec) place.path = target.string();
  }
  const fs::file_status status = fs::status(place.path, ec);
  place.replaceByRename = !fs::exists(status) || fs::is_regular_file(status);
  return place;
}

std::string directoryOf(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

}  // namespace blobvk::mesh
