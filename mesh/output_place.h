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

// errno values for which a temporary beside the file, or renaming it over the file, cannot work
// while writing the file itself may (a folder not writable, a file bind-mounted into a container).
bool renameImpossible(int err);

// Gives a finished temporary `fd` the mode of the file at `path` it will replace, else the one an
// ordinary create would give (0666 less the umask): mkstemp makes 0600.
void setReplacementMode(int fd, const std::string& path);

// The folder of a path as written ("." for a bare name, "/" for one under the root).
std::string directoryOf(const std::string& path);

}  // namespace blobvk::mesh
