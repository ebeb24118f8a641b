// Mesh files written while the mesh is produced (a MeshSink), for meshes larger than memory.
// Every format's sections (PLY: vertices, faces; OBJ: v, vn, f; STL: facets) are spooled to
// unlinked temporary files; finish() writes the header, whose counts are only known at the end,
// and joins the sections after it with in-kernel copies (copy_file_range, sendfile). The bytes
// are the in-memory writers' (io.h) for the same mesh. A file output appears by rename when
// complete, never half-written; spooled sections take about the output's size on disk again.
#pragma once

#include "blobvk/mesh/mesh_sink.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace blobvk::mesh {

struct StreamedFileOptions {
  std::string format = "ply";  // ply, obj or stl (as encodeMesh)
  bool asciiPly = false;       // PLY: ascii instead of binary_little_endian
  bool normals = true;         // the vertex runs carry normals (and the file stores them)
  bool colours = true;         // ... colours
  // Where spooled sections go; empty: beside the output (or $TMPDIR, /tmp for standard output).
  std::string spoolDirectory;
  // finish() copies the sections into the file in pieces of this many bytes, on a few threads.
  std::uint64_t copyPieceBytes = 64u << 20;
};

class StreamedMeshFile final : public MeshSink {
 public:
  // `path` "-" writes standard output. Throws std::runtime_error naming the path when the spool
  // or output files cannot be created, std::invalid_argument for an unknown format.
  StreamedMeshFile(const std::string& path, const StreamedFileOptions& options);
  ~StreamedMeshFile() override;  // an unfinished output is removed
  StreamedMeshFile(const StreamedMeshFile&) = delete;
  StreamedMeshFile& operator=(const StreamedMeshFile&) = delete;

  void vertices(std::span<const Float3> positions, std::span<const Float3> normals,
                std::span<const Float3> colours) override;
  void triangles(std::span<const std::array<std::uint32_t, 3>> triangles,
                 const VertexWindow& window) override;

  // Header, then the sections; renames the file into place. Returns the file's size in bytes.
  std::uint64_t finish();

  std::uint64_t vertexCount() const { return vertices_; }
  std::uint64_t triangleCount() const { return triangles_; }

  // A file written by several processes, each holding the runs of some layers (apps/mesh_mpi.h):
  // each process's object spools its own runs and never calls finish(); the processes agree on
  // where every run goes and each copies its runs into one shared file.
  //
  // Bytes each section (PLY: vertices, faces; OBJ: v, [vn,] f; STL: facets) holds so far.
  std::vector<std::uint64_t> sectionBytes() const;
  // The header finish() would write for a mesh of these counts.
  std::string headerFor(std::uint64_t vertices, std::uint64_t triangles) const;
  struct Placement {
    int section;
    std::uint64_t from, length;  // bytes of the section
    std::uint64_t to;            // offset in the file
  };
  // Copies the ranges into `fd` at their offsets (leaving its file position alone, so that other
  // processes can fill the rest of the file at once), on a few threads.
  void place(int fd, const std::vector<Placement>& placements);

  // For the process that assembles such a file: `bytes` written into `fd` at `offset` (its file
  // position left alone), and the file's first `length` bytes appended to `out` (standard
  // output); `what` names the file in the error thrown.
  static void writeAt(int fd, const std::string& bytes, std::uint64_t offset, const std::string& what);
  static void append(int in, int out, std::uint64_t length, const std::string& what);

 private:
  class Spool;
  std::string header() const { return headerFor(vertices_, triangles_); }

  std::string path_;
  StreamedFileOptions options_;
  std::vector<std::unique_ptr<Spool>> sections_;
  std::string text_;  // encoding scratch
  std::uint64_t vertices_ = 0, triangles_ = 0;
  bool finished_ = false;
};

}  // namespace blobvk::mesh
