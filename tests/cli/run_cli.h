// Runs the blobvk binary (path in BLOBVK_CLI) as a user would: shared by the end-to-end suites.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace blobvk::testing {

struct CliRun {
  int status = -1;
  std::string output;  // stdout and stderr together
};

inline CliRun runCli(const std::string& args) {
  const std::string command = std::string(BLOBVK_CLI) + " " + args + " 2>&1";
  CliRun r;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), int(buf.size()), pipe)) r.output += buf.data();
  const int raw = pclose(pipe);
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return r;
}

inline std::string fileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Standard output and standard error apart (binary-safe), run from `cwd`; stdin is /dev/null and
// neither stream is a terminal, as in a script.
struct CliSplitRun {
  int status = -1;
  std::string out, err;
};

inline CliSplitRun runCliSplit(const std::string& args, const std::filesystem::path& cwd) {
  std::filesystem::create_directories(cwd);
  const auto outFile = cwd / ".stdout", errFile = cwd / ".stderr";
  const std::string command = "cd '" + cwd.string() + "' && " + BLOBVK_CLI + " " + args + " </dev/null >'" +
                              outFile.string() + "' 2>'" + errFile.string() + "'";
  CliSplitRun r;
  const int raw = std::system(command.c_str());
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = fileBytes(outFile);
  r.err = fileBytes(errFile);
  std::filesystem::remove(outFile);
  std::filesystem::remove(errFile);
  return r;
}

}  // namespace blobvk::testing
