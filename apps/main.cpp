// blobvk: implicit models to meshes and images. See README.md and `blobvk --help`.
// Exit status: 0 success, 1 error, 2 usage error, 3 a failed `compare` (cli_conventions.h).
#include "backends.h"
#include "cli_conventions.h"
#include "commands.h"
#include "number_checks.h"
#include "render_command.h"

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {
// The subcommands given, "generate tower " ("" for none), and the innermost one's App.
std::string givenCommand(const CLI::App* app, const CLI::App** innermost = nullptr) {
  std::string command;
  for (const CLI::App* a = app; a;) {
    const std::vector<const CLI::App*> given = a->get_subcommands([](const CLI::App* s) { return s->parsed(); });
    a = given.empty() ? nullptr : given.front();
    if (a) {
      command += a->get_name() + " ";
      if (innermost) *innermost = a;
    }
  }
  return command;
}

// CLI11's wording where it misleads: a range check that also fails on a word, a count of
// values, and extra arguments listed last first. (Plain string matching: GCC 12's <regex> trips
// -Wmaybe-uninitialized in the sanitizer build.)
std::string clearerParseMessage(const std::string& what) {
  // "--threads: Value x not in range 0 to 1024"
  const std::string value = ": Value ", range = " not in range ", to = " to ";
  if (const auto v = what.find(value), r = what.find(range); what.rfind("--", 0) == 0 && v != std::string::npos && r != std::string::npos && v < r) {
    const std::string option = what.substr(0, v), given = what.substr(v + value.size(), r - v - value.size());
    const std::string bounds = what.substr(r + range.size());
    const auto t = bounds.find(to);
    if (t != std::string::npos) {
      char* end = nullptr;
      (void)std::strtod(given.c_str(), &end);
      const bool number = !given.empty() && end && *end == '\0';
      return option + ": " + (number ? given + " is not within [" + bounds.substr(0, t) + ", " + bounds.substr(t + to.size()) + "]"
                                     : "'" + given + "' is not a number");
    }
  }
  // "--resolution: At Most 1 required but received 2"
  const std::string atMost = ": At Most 1 required but received ";
  if (const auto a = what.find(atMost); what.rfind("--", 0) == 0 && a != std::string::npos)
    return what.substr(0, a) + " takes one value, got " + what.substr(a + atMost.size());
  // "The following arguments were not expected: --res 8" (CLI11 lists them last first)
  for (const std::string extra : {"The following argument was not expected: ", "The following arguments were not expected: "}) {
    if (what.rfind(extra, 0) != 0) continue;
    std::vector<std::string> words;
    std::istringstream in(what.substr(extra.size()));
    for (std::string w; in >> w;) words.push_back(w);
    std::string listed;
    for (auto it = words.rbegin(); it != words.rend(); ++it) listed += (listed.empty() ? "" : " ") + *it;
    return std::string(words.size() == 1 ? "an unexpected argument: " : "unexpected arguments: ") + listed;
  }
  return what;
}
}  // namespace

int main(int argc, char** argv) {
  // lavapipe tuning, set by the process (the library never touches the environment) and only
  // where the user has not chosen: llvmpipe picks 512-bit vectors on AVX-512 CPUs, and 256-bit
  // ones measured faster for every kernel (docs/vulkan.md). Other drivers ignore it.
  setenv("LP_NATIVE_VECTOR_WIDTH", "256", 0);
  // --threads N is N threads, up to the 1024 the option allows: TBB would otherwise cap its
  // workers at the core count and print a two-line warning past it, even under -q.
  const tbb::global_control threadLimit(tbb::global_control::max_allowed_parallelism, 1024);
  using namespace blobvk::app;
  CLI::App app{"blobvk: BlobTree implicit models to meshes, images and soft bodies"};
  app.require_subcommand(1);
  app.set_version_flag("--version", versionString());
  // Global flags may also follow the subcommand (`blobvk mesh ... -q`): subcommands created
  // below inherit fallthrough and hand options they do not know to this parent.
  app.fallthrough();
  // A flag is given or not: `--stream=false` would count as given for every rule between options
  // (`--feature-angle` needs `--features`) while it turned the flag off, so values are refused.
  // Subcommands copy these defaults when created below.
  app.option_defaults()->disable_flag_override();
  bool quietFlag = false;
  app.add_flag("-q,--quiet", quietFlag, "No progress or informational lines on stderr (mesh, render: no summary); warnings still print");
  app.parse_complete_callback([&quietFlag] { setQuiet(quietFlag); });
  // Where the Vulkan pipeline cache lives (vk/device/standalone.h): passed to the library through the
  // variable it reads, so every command that creates a device honours it.
  app.add_option_function<std::string>(
         "--pipeline-cache", [](const std::string& dir) { setenv("BLOBVK_PIPELINE_CACHE", dir.c_str(), 1); },
         "Vulkan pipeline cache directory, or 'off' (default: $BLOBVK_PIPELINE_CACHE, else "
         "$XDG_CACHE_HOME/blobvk or ~/.cache/blobvk)")
      ->type_name("DIR|off")
      ->check(nonEmptyText())
      ->trigger_on_parse();
  // Usage errors are one line and exit 2 whatever CLI11's own code for them.
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    // CLI11 reports through the tool itself; the help to point at is the innermost subcommand
    // that was given ("generate tower "), "" where none was.
    const CLI::App* innermost = failed;
    const std::string command = givenCommand(failed, &innermost);
    std::string what = clearerParseMessage(e.what());
    // CLI11 says "stream was given a disallowed flag override" (its name without dashes).
    const std::string override = " was given a disallowed flag override";
    if (const auto at = what.find(override); at != std::string::npos && at + override.size() == what.size())
      what = "--" + what.substr(0, at) + " is a flag: it takes no value";
    // A mistyped command reads as a missing one to CLI11: name the word and the commands.
    if (what == "A subcommand is required") {
      const std::vector<std::string> left = failed->remaining(true);
      const auto word = std::find_if(left.begin(), left.end(), [](const std::string& w) { return !w.empty() && w[0] != '-'; });
      std::string commands;
      for (const CLI::App* s : innermost->get_subcommands([](const CLI::App*) { return true; }))
        commands += (commands.empty() ? "" : ", ") + s->get_name();
      // "generate -o x.json": an option before the command makes its value look like a command.
      if (!left.empty() && left.front().size() > 1 && left.front()[0] == '-')
        what = "'" + left.front() + "' comes before the command: blobvk " + command + "takes one of " + commands + " first";
      else if (word != left.end())
        what = "'" + *word + "' is not a command of blobvk " + command + "(" + commands + ")";
    }
    return "blobvk: usage error: " + printable(what) + " (see blobvk " + command + "--help)\n";
  });
  addGenerateCommand(app);
  addMeshCommand(app);
  addInfoCommand(app);
  addConvertCommand(app);
  addBenchCommand(app);
  addSimulateCommand(app);
  addCutCommand(app);
  addEditCommand(app);
  addDevicesCommand(app);
  addCompareCommand(app);
  addRenderCommand(app);
  // The shared Vulkan devices go before main returns, on every path (apps/backends.cpp says why).
  struct ReleaseDevices {
    ~ReleaseDevices() { releaseSharedDevices(); }
  } releaseDevices;
  try {
    app.parse(argc, argv);
    // Reports printed on stdout (summaries, --json) are the command's output too: a full disk
    // or closed pipe must not end in exit status 0 with an empty file.
    errno = 0;
    if (std::fflush(stdout) != 0 || std::ferror(stdout))
      throw std::runtime_error("standard output: write error: " + systemReason(errno ? errno : EIO));
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "blobvk: usage error: %s (see blobvk %s--help)\n", printable(e.what()).c_str(),
                 givenCommand(&app).c_str());
    return kExitUsage;
  } catch (const ComparisonFailed& e) {
    // The report on stdout first (a CI log that merges the two streams reads it before the
    // verdict), and a report that could not be written is an error like any failed write.
    errno = 0;
    const bool reportLost = std::fflush(stdout) != 0 || std::ferror(stdout);
    const int reportErrno = errno ? errno : EIO;
    std::fprintf(stderr, "blobvk: comparison failed: %s\n", printable(e.message).c_str());
    if (reportLost) {
      std::fprintf(stderr, "blobvk: error: standard output: write error: %s\n", systemReason(reportErrno).c_str());
      return kExitError;
    }
    return kExitComparisonFailed;
  } catch (const std::exception& e) {
    // One clear line; the library's messages already name the file and the place.
    std::fprintf(stderr, "blobvk: error: %s\n", printable(e.what()).c_str());
    return kExitError;
  }
  return 0;
}
