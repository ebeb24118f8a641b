// Runs a fuzz target over files and directories given on the command line (no libFuzzer
// needed), so CI replays the checked-in corpus (tests/fuzz/corpus/<target>/, which also keeps
// every input a fuzzer ever failed on) on each build. A replay must never pass hollow: a path
// that does not exist, a directory without a single input, or no path at all fails the run.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

bool runFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "replay: %s: cannot open\n", path.c_str());
    return false;
  }
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  return true;
}

// Replays one argument; returns the number of inputs run, or -1 when the path is unusable.
long replayPath(const std::filesystem::path& path) {
  std::error_code error;
  if (std::filesystem::is_regular_file(path, error)) return runFile(path) ? 1 : -1;
  if (!std::filesystem::is_directory(path, error)) {
    std::fprintf(stderr, "replay: %s: no such file or directory\n", path.c_str());
    return -1;
  }
  // Sorted, so a crash report names the same input on every machine.
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(path)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    std::fprintf(stderr, "replay: %s: corpus folder holds no input\n", path.c_str());
    return -1;
  }
  for (const auto& file : files) {
    if (!runFile(file)) return -1;
  }
  return long(files.size());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR_OR_FILE...\n", argv[0]);
    return 2;
  }
  long count = 0;
  for (int i = 1; i < argc; ++i) {
    const long n = replayPath(argv[i]);
    if (n < 0) return 1;
    std::printf("replayed %ld inputs from %s\n", n, argv[i]);
    count += n;
  }
  std::printf("replayed %ld inputs\n", count);
  return 0;
}
