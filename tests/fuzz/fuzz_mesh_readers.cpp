// Fuzz target: the PLY, OBJ and STL readers. They take paths, so the input goes through a
// per-process temporary file; the first byte picks the format.
#include "blobvk/mesh/io.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0 || size > (1u << 16)) return 0;
  static const char* kExtensions[] = {".ply", ".obj", ".stl"};
  const std::string path = "/tmp/blobvk_fuzz_" + std::to_string(getpid()) + kExtensions[data[0] % 3];
  if (std::FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
  }
  try {
    (void)blobvk::mesh::readMesh(path);
  } catch (const std::runtime_error&) {
  } catch (const std::invalid_argument&) {
  }
  std::remove(path.c_str());
  return 0;
}
