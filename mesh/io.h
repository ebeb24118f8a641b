// Mesh files: PLY (ascii / binary little endian), OBJ and binary STL writers, and readers for
// the same. Writers are byte-deterministic (shortest round-trip float text, fixed headers), so a
// mesh and its file hash the same on every run. Readers treat the file as hostile: every count
// is checked against the bytes left, every index against the vertex count, and any problem
// throws std::runtime_error naming the file and the fault.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <string>

namespace blobvk::mesh {

// PLY: vertex x y z [nx ny nz] [red green blue as uchar], face list uchar int vertex_indices.
void writePly(const TriMesh& mesh, const std::string& path, bool binary = true);
// OBJ: "v x y z [r g b]", "vn" when normals are present, "f a//a b//b c//c" (1-based).
void writeObj(const TriMesh& mesh, const std::string& path);
// Binary STL: per-facet normals from the geometry; vertex normals and colours are not stored.
void writeStl(const TriMesh& mesh, const std::string& path);
// The bytes each writer writes, for streams (the CLI's "-o -") and in-memory use.
std::string encodePly(const TriMesh& mesh, bool binary = true);
std::string encodeObj(const TriMesh& mesh);
std::string encodeStl(const TriMesh& mesh);
// By format name "ply" (binary), "obj" or "stl" (a leading dot and any case accepted).
std::string encodeMesh(const TriMesh& mesh, const std::string& format);
// Picks the writer by extension (.ply binary, .obj, .stl; case-insensitive).
// Throws std::invalid_argument for any other extension.
void writeMesh(const TriMesh& mesh, const std::string& path);

// PLY ascii or binary_little_endian: x y z required; nx ny nz and red green blue (uchar, scaled
// to [0, 1], or float) read when all three are present; other properties and elements skipped;
// polygons are fanned into triangles.
TriMesh readPly(const std::string& path);
// OBJ: v (with optional r g b), vn, f (v, v/vt, v//vn, v/vt/vn, negative = relative); polygons
// fanned. Normals are kept only when they pair one-to-one with the vertices (as writeObj writes).
TriMesh readObj(const std::string& path);
// STL, binary or ascii; identical positions are welded (first use order).
TriMesh readStl(const std::string& path);
// Picks the reader by extension; throws std::invalid_argument for any other.
TriMesh readMesh(const std::string& path);

}  // namespace blobvk::mesh
