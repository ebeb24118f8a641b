#include "blobvk/mesh/output_place.h"

#include <sys/stat.h>

#include <cerrno>
#include <filesystem>

namespace blobvk::mesh {

OutputPlace resolveOutputPlace(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // Follow the links by hand: weakly_canonical stops at a link whose target does not exist yet,
  // and renaming onto that link would replace it with a file. 40 hops, as the kernel allows.
  fs::path p(path);
  int hops = 0;
  while (fs::is_symlink(fs::symlink_status(p, ec))) {
    const fs::path target = fs::read_symlink(p, ec);
    if (ec || ++hops > 40) return {path, false};  // a loop or an unreadable link: written into, failing there
    p = target.is_absolute() ? target : p.parent_path() / target;
  }
  OutputPlace place{hops ? p.lexically_normal().string() : path, true};
  const fs::file_status status = fs::status(place.path, ec);
  place.replaceByRename = !fs::exists(status) || fs::is_regular_file(status);
  return place;
}

bool renameImpossible(int err) { return err == EACCES || err == EPERM || err == EROFS || err == EBUSY || err == EXDEV; }

void setReplacementMode(int fd, const std::string& path) {
  struct stat old {};
  if (::stat(path.c_str(), &old) == 0) {
    ::fchmod(fd, old.st_mode & 07777);
    return;
  }
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
}

std::string directoryOf(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

}  // namespace blobvk::mesh
