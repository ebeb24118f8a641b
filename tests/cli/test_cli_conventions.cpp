// The conventions every command follows (apps/cli_conventions.h): exit codes, --version, --quiet,
// output checked before work, "-" for standard output, the one resolution limit, error text.
#include "cli_files.h"
#include "run_cli.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/io.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace blobvk::testing;
namespace fs = std::filesystem;

std::size_t lineCount(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

fs::path dir(const std::string& name) {
  const fs::path d = scratchDir() / name;
  fs::create_directories(d);
  return d;
}

const std::string tower = sourcePath("scenes/tower.json");

TEST(CliConventions, VersionIsTheProjectVersion) {
  const CliSplitRun r = runCliSplit("--version", dir("version"));
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out, std::string("blobvk ") + BLOBVK_VERSION + "\n");
}

// An empty mesh is written (a valid answer) with exit 0, but with a warning that says why it
// may be empty, which -q does not silence.
TEST(CliConventions, AnEmptyMeshIsWrittenWithAWarning) {
  const fs::path cwd = dir("empty");
  CliSplitRun r = runCliSplit("mesh " + tower + " -o e.ply --resolution 2", cwd);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("warning: the mesh is empty: no surface crosses the 4 x 4 x 4 grid"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(cwd / "e.ply"));
  r = runCliSplit("mesh " + tower + " -o s.ply --resolution 2 --stream", cwd);  // streamed alike
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("warning: the mesh is empty"), std::string::npos) << r.err;
  EXPECT_EQ(fileBytes(cwd / "s.ply"), fileBytes(cwd / "e.ply"));  // the same bytes, header included
  r = runCliSplit("mesh " + tower + " -o e.ply --resolution 2 -q", cwd);  // a warning is not progress
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.err.find("warning: the mesh is empty"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  r = runCliSplit("mesh " + tower + " -o f.ply --resolution 16", cwd);
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
}

TEST(CliConventions, UsageErrorsExitTwoWithOneLine) {
  const fs::path cwd = dir("usage");
  for (const std::string& args : std::vector<std::string>{std::string(""), "mesh", "mesh " + tower + " -o x.ply --bogus",
                                 "mesh " + tower + " -o x.ply --resolution abc", "mesh " + tower + " -o x.ply --backend nope",
                                 "generate", "render " + tower + " -o t.jpg", "convert " + tower + " out.blob",
                                 "mesh " + tower + " -o x.xyz", "bench " + tower + " --traversal sideways",
                                 "mesh " + tower + " -o x.ply --max-memory 0",
                                 "compare " + tower + " --max-field-diff nan", "generate random --seed -1 -o r.json",
                                 "generate random --seed 99999999999999999999999 -o r.json",
                                 // Options that would do nothing: another backend's, or a switch's
                                 // parameter without the switch.
                                 "mesh " + tower + " -o x.ply --traversal stackless",
                                 "mesh " + tower + " -o x.ply --device 0", "mesh " + tower + " -o x.ply --backend vk --mpu 8",
                                 "bench " + tower + " --brick-cells 8", "mesh " + tower + " -o x.ply --feature-angle 20",
                                 "mesh " + tower + " -o x.ply --features --feature-angle nan",
                                 "mesh " + tower + " -o x.ply --no-optimize", "compare " + tower + " --image-size 64",
                                 "compare " + tower + " --write-images out", "compare " + tower + " --cpu-backend vk",
                                 // NaN passes CLI11's own range checks; not these.
                                 "mesh " + tower + " -o x.ply --cell-size nan", "mesh " + tower + " -o x.ply --cell-size 1e30",
                                 "render " + tower + " -o x.png --fov nan",
                                 "generate tower --radius nan -o t.json", "compare " + tower + " --max-hausdorff inf",
                                 // What cannot stream, asked to.
                                 "mesh " + tower + " -o x.glb --stream", "mesh " + tower + " -o x.ply --stream --backend reference",
                                 // An empty value is not the option left out; --max-triangles 0 read as no limit.
                                 "mesh " + tower + " -o x.ply --simplify ''", "mesh " + tower + " -o x.ply --backend vk --device ''",
                                 "mesh " + tower + " -o x.ply --max-triangles 0", "--pipeline-cache '' info " + tower,
                                 "render " + tower + " -o x.png --camera ''", "render " + tower + " -o x.png --eye ''",
                                 "render " + tower + " -o x.png --target ''",
                                 // An MPU of one cell: the help's range, not the polygonizer's own error.
                                 "mesh " + tower + " -o x.ply --mpu 1", "bench " + tower + " --mpu 1",
                                 // The scene format's camera ranges; the voxel mesher's cell on a TetGen body.
                                 "render " + tower + " -o x.png --camera 30,20,-5", "render " + tower + " -o x.png --eye 1e30,0,0",
                                 "render " + tower + " -o x.png --camera 30,20,1e300", "render " + tower + " -o x.png --eye +-1,2,3",
                                 "render " + tower + " -o x.png --eye '                    ,1,2'",
                                 "cut " + sourcePath("scenes/soft_peanut.json") + " -o cut_out --voxel-cell 0.05",
                                 // A flag given a value (it would count as given while off).
                                 "mesh " + tower + " -o x.ply --stream=false",
                                 "mesh " + tower + " -o x.ply --features=false --feature-angle 30", "mesj " + tower}) {
    const CliSplitRun r = runCliSplit(args, cwd);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.err;
    EXPECT_EQ(lineCount(r.err), 1u) << args << "\n" << r.err;
    EXPECT_NE(r.err.find("usage error"), std::string::npos) << args << "\n" << r.err;
  }
  // The option is named, not only the value, and the help pointed at is the command's.
  EXPECT_NE(runCliSplit("mesh " + tower + " -o x.ply --max-memory 0", cwd).err.find("--max-memory: '0'"), std::string::npos);
  EXPECT_NE(runCliSplit("mesh " + tower + " -o x.ply --resolution abc", cwd).err.find("(see blobvk mesh --help)"), std::string::npos);
  EXPECT_NE(runCliSplit("generate tower --radius nan -o t.json", cwd).err.find("(see blobvk generate tower --help)"), std::string::npos);
  EXPECT_NE(runCliSplit("mesh " + tower + " -o x.ply --stream=false", cwd).err.find("--stream is a flag: it takes no value"), std::string::npos);
  // CLI11's wording made plain: a word for a number, a value out of range, extra words in the
  // order given; the commands' own usage errors point at the help too.
  EXPECT_NE(runCliSplit("mesh " + tower + " -o x.ply --threads x", cwd).err.find("--threads: 'x' is not a number (see blobvk mesh --help)"),
            std::string::npos);
  EXPECT_NE(runCliSplit("mesh " + tower + " -o x.ply --threads 5000", cwd).err.find("--threads: 5000 is not within [0, 1024]"),
            std::string::npos);
  EXPECT_NE(runCliSplit("mesh " + tower + " -o x.ply 8 --res", cwd).err.find("unexpected arguments: 8 --res"), std::string::npos);
  EXPECT_NE(runCliSplit("mesh " + tower + " -o x.glb --stream", cwd).err.find("in memory (see blobvk mesh --help)"), std::string::npos);
  EXPECT_NE(runCliSplit("--pipeline-cache off mesj " + tower, cwd).err.find("'mesj' is not a command of blobvk (generate, mesh,"), std::string::npos);
  EXPECT_NE(runCliSplit("generate towr", cwd).err.find("'towr' is not a command of blobvk generate (tower, eggshell, random)"), std::string::npos);
  // Options that would do nothing within the backends the job runs, each with the line naming why.
  const std::vector<std::pair<std::string, std::string>> refusals = {
      // --tiled-vertices is the dense pipeline's: it must not switch mesh or bench to it unasked.
      {"mesh " + tower + " -o x.ply --backend vk --tiled-vertices", "the sparse extraction's vertex pass per tile is --vertex-tiles"},
      {"bench " + tower + " --backend vk --tiled-vertices", "--tiled-vertices is for the dense pipeline (--dense)"},
      // Within the vk backend: pruned kernels are generated code's, bricks the sparse extraction's.
      {"mesh " + tower + " -o x.ply --backend vk --traversal stackless --field-tiles 4", "--field-tiles is for the specialised traversal"},
      {"mesh " + tower + " -o x.ply --backend vk --field-tiles 1 --vertex-tiles", "--vertex-tiles is for more than one field tile"},
      {"bench " + tower + " --backend vk --dense --brick-cells 8", "--brick-cells is for the sparse extraction, not --dense"},
      // CPU options that no backend of the job uses: the vk backend's CPU worker takes --threads only.
      {"mesh " + tower + " -o x.ply --backend reference --threads 2", "--threads is for the cpu backend and the vk backend's --cpu-worker"},
      {"mesh " + tower + " -o x.ply --backend vk --cpu-worker --mpu 8", "--mpu is for the cpu backend"},
      {"bench " + tower + " --backend vk --batches-per-device 2", "--batches-per-device is for several devices (--devices)"},
      {"generate -o x.json", "'-o' comes before the command: blobvk generate takes one of tower, eggshell, random first"}};
  for (const auto& [args, why] : refusals) EXPECT_NE(runCliSplit(args, cwd).err.find(why), std::string::npos) << args;
  EXPECT_TRUE(fs::is_empty(cwd)) << "a refused command wrote a file";
  EXPECT_EQ(runCliSplit("--help", cwd).status, 0);
  EXPECT_EQ(runCliSplit("mesh --help", cwd).status, 0);
}

// The output's format is its extension: a name that promises another format is refused before any
// work, naming what is supported.
TEST(CliConventions, OutputExtensionIsChecked) {
  const fs::path cwd = dir("extensions");
  CliSplitRun r = runCliSplit("render " + tower + " -o t.jpg", cwd);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find(".png"), std::string::npos) << r.err;
  r = runCliSplit("convert " + sourcePath("scenes/legacy/peanut.blob") + " a.blob", cwd);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find(".json"), std::string::npos) << r.err;
  r = runCliSplit("mesh " + tower + " -o m.fbx", cwd);
  EXPECT_EQ(r.status, 2);
  for (const char* ext : {".ply", ".obj", ".stl", ".gltf", ".glb"}) EXPECT_NE(r.err.find(ext), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_empty(cwd));
  // Any case of a supported extension is that format.
  r = runCliSplit("mesh " + tower + " -o upper.STL --resolution 16 -q", cwd);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_GT(blobvk::mesh::readStl((cwd / "upper.STL").string()).triangleCount(), 100u);
}

// The output place is checked first: with an unreadable scene AND an unwritable output, the
// error is about the output (the scene was never opened, nothing was computed).
TEST(CliConventions, UnwritableOutputFailsBeforeAnyWork) {
  const fs::path cwd = dir("unwritable");
  CliSplitRun r = runCliSplit("mesh nope.json -o /nonexistent/x.ply", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err, "blobvk: error: /nonexistent/x.ply: cannot write: No such file or directory\n");
  r = runCliSplit("mesh " + tower + " -o /nonexistent/x.ply --resolution 2000", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(lineCount(r.err), 1u) << r.err;  // no progress line: polygonization never started
  r = runCliSplit("render nope.json -o /nonexistent/t.png", cwd);
  EXPECT_NE(r.err.find("/nonexistent/t.png: cannot write"), std::string::npos) << r.err;
  r = runCliSplit("convert nope.json /nonexistent/t.json", cwd);
  EXPECT_NE(r.err.find("/nonexistent/t.json: cannot write"), std::string::npos) << r.err;
  r = runCliSplit("generate eggshell -o /nonexistent/e.json", cwd);
  EXPECT_NE(r.err.find("/nonexistent/e.json: cannot write"), std::string::npos) << r.err;
  // Folders of frames are created up front; a file in the way is reported with the reason.
  std::ofstream(cwd / "file") << "x";
  r = runCliSplit("simulate nope.json -o file/sub", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("file/sub: cannot create the folder"), std::string::npos) << r.err;
  // compare's image folder too, before the scene is read.
  r = runCliSplit("compare nope.json --images --write-images file/imgs", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(lineCount(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("file/imgs: cannot create the image folder"), std::string::npos) << r.err;
  r = runCliSplit("mesh " + tower + " -o .", cwd);
  EXPECT_NE(r.status, 0);
}

// A full disk is an error wherever the output goes: reports printed on standard output (a
// summary, --json) and PNG images alike exit 1 with one line, never 0 with an empty file.
TEST(CliConventions, AFullDiskIsAnErrorForReportsAndImages) {
  const fs::path cwd = dir("full");
  const auto runToFull = [&cwd](const std::string& args) {
    const std::string command = "cd '" + cwd.string() + "' && " + BLOBVK_CLI + " " + args + " </dev/null >/dev/full 2>err.txt";
    const int raw = std::system(command.c_str());
    return std::make_pair(WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, fileBytes(cwd / "err.txt"));
  };
  for (const std::string& args : std::vector<std::string>{"info " + tower, "info " + tower + " --json", "mesh " + tower + " -o m.ply --resolution 8",
                                 "bench " + tower + " --resolution 8 --repeats 1 --json"}) {
    const auto [status, err] = runToFull(args);
    EXPECT_EQ(status, 1) << args << "\n" << err;
    // Progress lines may come first; the error is the last line, and the only one.
    EXPECT_NE(err.find("blobvk: error: standard output: write error: No space left on device\n"), std::string::npos) << args << "\n" << err;
    EXPECT_EQ(err.find("blobvk: error"), err.rfind("blobvk: error")) << args << "\n" << err;
  }
  if (!BLOBVK_CLI_WITH_VULKAN) return;
  fs::remove(cwd / "full.png");
  fs::create_symlink("/dev/full", cwd / "full.png");
  const CliSplitRun r = runCliSplit("render " + tower + " -o full.png --size 32x32", cwd);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("write error: No space left on device"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("blobvk: error"), r.err.rfind("blobvk: error")) << r.err;
  EXPECT_EQ(r.err.find("libpng"), std::string::npos) << r.err;  // no line of libpng's own
  EXPECT_TRUE(fs::is_symlink(cwd / "full.png"));  // a device given as the output is left alone
}

// An output that is a symlink is written through it (the link stays), and a FIFO is written
// into, never renamed over, in memory and streamed alike: the same bytes as a plain file.
TEST(CliConventions, SymlinksAndFifosAsOutputsAreWrittenThrough) {
  const fs::path cwd = dir("places");
  ASSERT_EQ(runCliSplit("mesh " + tower + " -o plain.ply --resolution 16", cwd).status, 0);
  const std::string plain = fileBytes(cwd / "plain.ply");
  for (const std::string mode : {"", " --stream"}) {
    fs::remove(cwd / "real.ply");
    fs::remove(cwd / "link.ply");
    std::ofstream(cwd / "real.ply") << "old";
    fs::create_symlink("real.ply", cwd / "link.ply");
    CliSplitRun r = runCliSplit("mesh " + tower + " -o link.ply --resolution 16" + mode, cwd);
    ASSERT_EQ(r.status, 0) << mode << r.err;
    EXPECT_TRUE(fs::is_symlink(cwd / "link.ply")) << mode;
    EXPECT_EQ(fileBytes(cwd / "real.ply"), plain) << mode;
    // A link whose target does not exist yet, through a second link: the target is made.
    fs::remove(cwd / "made.ply");
    fs::remove(cwd / "dangling.ply");
    fs::remove(cwd / "chain.ply");
    fs::create_symlink("made.ply", cwd / "dangling.ply");
    fs::create_symlink("dangling.ply", cwd / "chain.ply");
    r = runCliSplit("mesh " + tower + " -o chain.ply --resolution 16" + mode, cwd);
    ASSERT_EQ(r.status, 0) << mode << r.err;
    EXPECT_TRUE(fs::is_symlink(cwd / "chain.ply") && fs::is_symlink(cwd / "dangling.ply")) << mode;
    EXPECT_EQ(fileBytes(cwd / "made.ply"), plain) << mode;
    // Meshes into a new named pipe `fifo` with `options`, a reader copying it to copy.ply in the
    // background (the shell waits for it before answering); the mesh's exit status.
    const auto meshThroughFifo = [&](const std::string& fifo, const std::string& options) {
      fs::remove(cwd / fifo);
      fs::remove(cwd / "copy.ply");
      EXPECT_EQ(::mkfifo((cwd / fifo).c_str(), 0600), 0);
      const std::string command = "cd '" + cwd.string() + "' && { cat " + fifo + " > copy.ply & " + BLOBVK_CLI + " -q mesh " +
                                  tower + " -o " + fifo + options + " --resolution 16" + mode + "; status=$?; wait; exit $status; }";
      return std::system(command.c_str());
    };
    ASSERT_EQ(meshThroughFifo("fifo.ply", ""), 0) << mode;
    EXPECT_EQ(fs::status(cwd / "fifo.ply").type(), fs::file_type::fifo) << mode;
    EXPECT_EQ(fileBytes(cwd / "copy.ply"), plain) << mode;
    // A place without an extension takes --format: a pipe, and /dev/null.
    ASSERT_EQ(meshThroughFifo("pipe", " --format ply"), 0) << mode;
    EXPECT_EQ(fileBytes(cwd / "copy.ply"), plain) << mode;
    r = runCliSplit("mesh " + tower + " -o /dev/null --format obj --resolution 16" + mode, cwd);
    EXPECT_EQ(r.status, 0) << mode << r.err;
  }
  // A name with an extension keeps it as its format.
  const CliSplitRun both = runCliSplit("mesh " + tower + " -o x.ply --format obj", cwd);
  EXPECT_EQ(both.status, 2) << both.err;
  EXPECT_NE(both.err.find("--format is for -o - or a name without an extension"), std::string::npos) << both.err;
}

TEST(CliConventions, ErrorsGiveTheSystemReasonAndOnlyPrintableBytes) {
  const fs::path cwd = dir("reasons");
  CliSplitRun r = runCliSplit("info nope.json", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err, "blobvk: error: nope.json: cannot open: No such file or directory\n");
  // A binary file named .blob: the parser's message quotes some of it; the line must stay text.
  std::string binary;
  for (int i = 0; i < 4096; ++i) binary += char((i * 37 + 11) & 0xff);
  std::ofstream(cwd / "binary.blob", std::ios::binary) << binary;
  r = runCliSplit("info binary.blob", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(lineCount(r.err), 1u);
  for (unsigned char c : r.err) EXPECT_TRUE((c >= 0x20 && c < 0x7f) || c == '\n') << int(c) << " in " << r.err;
  EXPECT_NE(r.err.find("binary.blob"), std::string::npos) << r.err;
}

// One limit for every --resolution that holds a mesh, derived from memory: the same number in
// every message.
TEST(CliConventions, OneResolutionLimitForAllCommands) {
  const fs::path cwd = dir("limits");
  const std::string huge = " --resolution 100000000";
  std::set<std::string> limits;
  for (const std::string& args : std::vector<std::string>{"render " + tower + " -o x.png", "bench " + tower,
                                 "compare " + tower, "simulate " + tower + " -o f", "cut " + tower + " -o f"}) {
    const CliSplitRun r = runCliSplit(args + huge, cwd);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.err;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.err, m, std::regex("is above ([0-9]+)"))) << args << "\n" << r.err;
    limits.insert(m[1]);
  }
  ASSERT_EQ(limits.size(), 1u);
  const long limit = std::stol(*limits.begin());
  // A machine with any memory takes a 512 grid; no machine has the bytes for a million cubed.
  EXPECT_GE(limit, 512);
  EXPECT_LT(limit, 1000000);
  // mesh streams what does not fit (--stream, --max-memory): its limit is the streamed one.
  const CliSplitRun mesh = runCliSplit("mesh " + tower + " -o x.ply" + huge, cwd);
  EXPECT_EQ(mesh.status, 2) << mesh.err;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(mesh.err, m, std::regex("is above ([0-9]+), the finest grid whose streamed"))) << mesh.err;
  EXPECT_GE(std::stol(m[1]), limit);
  EXPECT_TRUE(fs::is_empty(cwd));
}

// Progress goes to stderr: lines in a pipe, nothing with -q (before or after the subcommand);
// stdout keeps only the product.
TEST(CliConventions, ProgressOnStderrAndQuiet) {
  const fs::path cwd = dir("progress");
  const std::string sim = "simulate " + sourcePath("scenes/soft_peanut.json") + " --steps 10 --no-png -o frames";
  CliSplitRun r = runCliSplit(sim, cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("simulate 100% (10/10)"), std::string::npos) << r.err;
  EXPECT_LE(lineCount(r.err), 14u) << "sparse lines, not one per step:\n" << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << "no terminal redraws into a pipe";
  EXPECT_EQ(r.out.find("100%"), std::string::npos);
  for (const std::string& q : std::vector<std::string>{"-q " + sim, sim + " --quiet"}) {
    r = runCliSplit(q, cwd);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "") << q;
    EXPECT_NE(r.out.find("10 steps"), std::string::npos) << r.out;
  }
  r = runCliSplit("mesh " + tower + " -o t.ply --resolution 48", cwd);
  EXPECT_NE(r.err.find("mesh 100%"), std::string::npos) << r.err;
  r = runCliSplit("mesh " + tower + " -o t.ply --resolution 48 -q", cwd);
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(r.out, "");
}

// On a terminal (util-linux `script` gives the command a pseudo-terminal) the progress is one
// bar redrawn in place, ending at 100 %.
TEST(CliConventions, ProgressIsABarOnATerminal) {
  const fs::path cwd = dir("tty");
  const std::string command = "cd '" + cwd.string() + "' && script -qec \"" + std::string(BLOBVK_CLI) + " mesh " + tower +
                              " -o t.ply --resolution 64\" /dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, pipe)) output.append(buf, n);
  ASSERT_EQ(pclose(pipe), 0) << output;
  EXPECT_NE(output.find("\rmesh ["), std::string::npos) << output;
  EXPECT_NE(output.find("[####################] 100%"), std::string::npos) << output;
  EXPECT_EQ(output.find("mesh 10% ("), std::string::npos) << "no log lines on a terminal";
}

// "-" is standard output for formats that stream; no file named "-" appears.
TEST(CliConventions, DashWritesToStandardOutput) {
  const fs::path cwd = dir("dash");
  CliSplitRun r = runCliSplit("mesh " + tower + " -o - --resolution 32", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(runCliSplit("mesh " + tower + " -o file.ply --resolution 32 -q", cwd).status, 0);
  EXPECT_EQ(r.out, fileBytes(cwd / "file.ply"));
  std::ofstream(cwd / "piped.ply", std::ios::binary) << r.out;
  const blobvk::mesh::MeshReport report = blobvk::mesh::checkMesh(blobvk::mesh::readPly((cwd / "piped.ply").string()));
  EXPECT_TRUE(report.watertight()) << report.summary();
  r = runCliSplit("mesh " + tower + " -o - --format obj --resolution 16", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.rfind("# written by blobvk", 0), 0u);

  r = runCliSplit("convert " + sourcePath("scenes/legacy/peanut.blob") + " -", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json scene = nlohmann::json::parse(r.out);
  EXPECT_EQ(scene["blobvk"], 1);
  EXPECT_GT(countJsonPrimitives(scene["root"]), 1u);
  r = runCliSplit("generate random --count 3 -o -", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(countJsonPrimitives(nlohmann::json::parse(r.out)["root"]), 3u);
#ifdef BLOBVK_HAVE_VULKAN
  r = runCliSplit("render " + tower + " -o - --size 40x30", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const Rgba image = decodePng(r.out);
  EXPECT_EQ(image.width, 40u);
  EXPECT_EQ(image.height, 30u);
  // Standard output as the shell gave it: a file opened for appending (>>) keeps what it held.
  std::ofstream(cwd / "log.bin", std::ios::binary) << "kept";
  const std::string command = "cd '" + cwd.string() + "' && " + BLOBVK_CLI + " render " + tower + " -o - --size 40x30 >>log.bin 2>/dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  EXPECT_EQ(fileBytes(cwd / "log.bin"), "kept" + r.out);
#endif
  EXPECT_FALSE(fs::exists(cwd / "-"));
  // Where stdout cannot carry the product, "-" is refused as a usage error.
  EXPECT_EQ(runCliSplit("mesh " + tower + " -o - --json", cwd).status, 2);
  r = runCliSplit("render " + tower + " -o - --turntable 3", cwd);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--turntable writes a file per frame"), std::string::npos) << r.err;
  EXPECT_EQ(runCliSplit("simulate " + tower + " -o -", cwd).status, 2);
  EXPECT_FALSE(fs::exists(cwd / "-"));
}

}  // namespace
