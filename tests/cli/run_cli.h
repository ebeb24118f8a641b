// Runs the blobvk binary (path in BLOBVK_CLI) as a user would: shared by the end-to-end suites.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
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

}  // namespace blobvk::testing
