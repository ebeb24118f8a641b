// The conventions every subcommand follows, in one place: exit codes, the global --quiet, output
// paths checked before any work ("-" for standard output where the format can stream), error
// text with the system's reason and only printable bytes.
#pragma once

#include <initializer_list>
#include <stdexcept>
#include <string>
#include <string_view>

namespace blobvk::app {

// Exit statuses: 0 success, 1 error, 2 usage error (bad flags, bad output name), 3 a comparison
// that ran but failed its thresholds.
inline constexpr int kExitError = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitComparisonFailed = 3;

// A command line that cannot be run as given (exit 2). Thrown by checks inside callbacks, where
// CLI11's own validators cannot see (e.g. an output extension that depends on --format).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// `blobvk -q ...` / `blobvk CMD -q`: no progress and no informational lines on stderr; commands
// whose only stdout is a summary (mesh, render) print nothing either.
bool quiet();
void setQuiet(bool quiet);

// An empty mesh is a valid answer (written, drawn, compared), but not without a word: one warning
// line, which -q does not silence (it silences progress and summaries). `command` as the line's
// prefix names it ("blobvk render"); `cells` the grid's cells per axis.
void warnEmptyMesh(const char* command, int cellsX, int cellsY, int cellsZ);

// "blobvk 0.1.0" (the CMake project version).
const char* versionString();

// Bytes outside printable ASCII (and tab) as \xNN, so a binary file quoted in an error cannot
// reach the terminal as raw bytes.
std::string printable(std::string_view text);

// strerror(err) as a std::string.
std::string systemReason(int err);

// Checks an output file before any work: "-" (standard output) only where `streamable`, the
// extension (case-insensitive, with the dot) among `extensions` (else a UsageError listing them),
// and the file writable (an existing writable file, or a writable existing folder to create it
// in; else "PATH: cannot write: <reason>"). Returns true for "-".
bool checkOutputFile(const std::string& path, std::initializer_list<std::string_view> extensions,
                     bool streamable, const char* what);

// Checks, creating nothing, that an output folder exists and is writable or could be created
// (its nearest existing ancestor is a writable folder): the output place is checked before the
// inputs are read, yet a job whose inputs fail leaves no folder behind.
// "PATH: cannot create the folder: <reason>" / "PATH: cannot write: <reason>".
void checkOutputFolder(const std::string& path);
// Creates an output folder (and its parents); the same errors.
void prepareOutputFolder(const std::string& path);

// Writes bytes to standard output (binary-safe); throws naming "standard output" on failure.
void writeStdout(std::string_view bytes);

// Writes bytes to `path`, or to standard output when path is "-". A regular file (or a new one)
// is written to a temporary beside it and renamed into place once whole; a symlink is followed;
// a device or FIFO is written into.
void writeOutput(const std::string& path, std::string_view bytes);

}  // namespace blobvk::app
