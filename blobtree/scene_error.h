// The one exception every scene reader throws. what() is a single line
// "<file>: <location>: <problem>", where location is a JSON pointer ("/root/children/2/radius")
// or "line N" for legacy .blob files, so a CLI can print it as is; "<file>: <problem>" where the
// problem is the whole file's (location empty: a folder, an unknown extension, a read error).
#pragma once

#include <stdexcept>
#include <string>

namespace blobvk::blobtree {

class SceneError : public std::runtime_error {
 public:
  SceneError(const std::string& file, const std::string& location, const std::string& problem)
      : std::runtime_error(file + ": " + (location.empty() ? "" : location + ": ") + problem),
        file_(file),
        location_(location),
        problem_(problem) {}

  const std::string& file() const { return file_; }
  const std::string& location() const { return location_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string file_, location_, problem_;
};

}  // namespace blobvk::blobtree
