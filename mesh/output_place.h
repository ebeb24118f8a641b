// Where an output file really goes, decided once for every writer that replaces a file by
// renaming a finished temporary onto it (streamed meshes, MPI ranks, the CLI's in-memory
// outputs): a rename must not replace a symlink with a file, nor a device (/dev/null) or FIFO.
#pragma once

#include <string>

namespace blobvk::mesh {

struct OutputPlace {
  // The path to write: the symlink's target where `path` is a symlink (followed to the end, also
  // to a target that does not exist yet).
  std::string path;
  // True for a regular file or a new one: write a temporary beside it and rename it into place,
  // so a failed write leaves the old file. False for a device, FIFO or socket (and a symlink
  // loop): written into.
  bool replaceByRename = true;
};

OutputPlace resolveOutputPlace(const std::string& path);

// The folder of a path as written ("." for a bare name, "/" for one under the root).
std::string directoryOf(const std::string& path);

}  // namespace blobvk::mesh
