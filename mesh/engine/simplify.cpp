// meshopt_simplify behind a closedness guard (see simplify.h).
#include "blobvk/mesh/engine/simplify.h"

#include "blobvk/mesh/checks.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <vector>

namespace blobvk::mesh {

SimplifyTarget parseSimplifyTarget(std::string_view text) {
  const std::string shown(text);
  const bool percent = !text.empty() && text.back() == '%';
  if (percent) text.remove_suffix(1);
  float v = 0.0f;
  const auto res = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || res.ec != std::errc() || res.ptr != text.data() + text.size() || !std::isfinite(v))
    throw std::invalid_argument("--simplify '" + shown + "': not a number (a ratio such as 0.25 or an error such as 0.5%)");
  if (percent) {
    if (!(v > 0.0f && v <= 100.0f)) throw std::invalid_argument("--simplify '" + shown + "': the error must be in (0%, 100%]");
    return {SimplifyTarget::Kind::Error, v / 100.0f};
  }
  if (!(v > 0.0f && v <= 1.0f)) throw std::invalid_argument("--simplify '" + shown + "': the ratio must be in (0, 1]");
  return {SimplifyTarget::Kind::Ratio, v};
}

namespace {

// Keeps the vertices `indices` use, in first-use order, with their attributes.
TriMesh packMesh(const TriMesh& in, const std::vector<unsigned>& indices) {
  std::vector<unsigned> remap(in.positions.size());
  const std::size_t n = meshopt_optimizeVertexFetchRemap(remap.data(), indices.data(), indices.size(), in.positions.size());
  TriMesh out;
  out.positions.resize(n);
  if (!in.normals.empty()) out.normals.resize(n);
  if (!in.colours.empty()) out.colours.resize(n);
  for (std::size_t v = 0; v < in.positions.size(); ++v) {
    const unsigned to = remap[v];
    if (to == ~0u) continue;  // not referenced any more
    out.positions[to] = in.positions[v];
    if (!in.normals.empty()) out.normals[to] = in.normals[v];
    if (!in.colours.empty()) out.colours[to] = in.colours[v];
  }
  out.triangles.resize(indices.size() / 3);
  for (std::size_t t = 0; t < out.triangles.size(); ++t)
    out.triangles[t] = {remap[indices[3 * t]], remap[indices[3 * t + 1]], remap[indices[3 * t + 2]]};
  return out;
}

// An edge collapse that closes a thin tunnel leaves two triangles over the same three vertices
// back to back (a "fin"): their three edges are used four times. Such pairs enclose nothing, so
// dropping both restores the manifold surface around them (and the input's Euler characteristic).
void dropFinPairs(std::vector<unsigned>& indices) {
  const std::size_t n = indices.size() / 3;
  std::vector<std::pair<std::array<unsigned, 3>, std::size_t>> keyed(n);
  for (std::size_t t = 0; t < n; ++t) {
    std::array<unsigned, 3> k{indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]};
    std::sort(k.begin(), k.end());
    keyed[t] = {k, t};
  }
  std::sort(keyed.begin(), keyed.end());  // ties broken by triangle index: deterministic
  std::vector<char> drop(n, 0);
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i + 1;
    while (j < n && keyed[j].first == keyed[i].first) ++j;
    if (j - i >= 2)
      for (std::size_t m = i; m < j; ++m) drop[keyed[m].second] = 1;
    i = j;
  }
  std::size_t w = 0;
  for (std::size_t t = 0; t < n; ++t)
    if (!drop[t])
      for (int k = 0; k < 3; ++k) indices[w++] = indices[3 * t + std::size_t(k)];
  indices.resize(w);
}

}  // namespace

TriMesh simplifyMesh(const TriMesh& mesh, const SimplifyTarget& target, SimplifyReport* report) {
  SimplifyReport r;
  r.trianglesBefore = mesh.triangles.size();
  const MeshReport before = checkMesh(mesh);
  r.watertightBefore = before.watertight();
  std::vector<unsigned> indices(mesh.triangles.size() * 3);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) indices[3 * t + std::size_t(k)] = mesh.triangles[t][std::size_t(k)];

  // A mesh with a boundary (cut by the grid's box) keeps its border in place, so it still meets
  // whatever it was cut against; a closed mesh has no border and the option changes nothing.
  const unsigned options = before.closed() ? 0u : unsigned(meshopt_SimplifyLockBorder);
  std::size_t targetIndices = 0;
  float targetError = std::numeric_limits<float>::max();
  if (target.kind == SimplifyTarget::Kind::Ratio) {
    targetIndices = 3 * std::size_t(std::llround(double(target.value) * double(mesh.triangles.size())));
  } else {
    targetError = target.value;
  }

  // Edge collapses can pinch a thin part into a non-manifold edge. Each retry moves the target
  // halfway back towards the input (and halves the error bound), which collapses fewer edges.
  constexpr int kAttempts = 6;
  std::vector<unsigned> out(indices.size());
  TriMesh result;
  bool found = false;
  for (int attempt = 0; attempt < kAttempts && !found; ++attempt) {
    ++r.attempts;
    float error = 0.0f;
    const std::size_t count = meshopt_simplify(out.data(), indices.data(), indices.size(), &mesh.positions[0].x,
                                               mesh.positions.size(), sizeof(Float3), targetIndices, targetError,
                                               options, &error);
    std::vector<unsigned> kept(out.begin(), out.begin() + std::ptrdiff_t(count));
    dropFinPairs(kept);
    TriMesh candidate = packMesh(mesh, kept);
    // Closed means the same surface topology too: watertight, the same Euler characteristic and
    // components (a collapse that shuts a window of the tower is not the same model).
    const MeshReport after = checkMesh(candidate);
    const bool watertight = after.watertight() && after.eulerCharacteristic == before.eulerCharacteristic &&
                            after.components == before.components;
    if (watertight || !r.watertightBefore) {  // an open input has no closedness to lose
      result = std::move(candidate);
      r.error = error;
      r.watertightAfter = watertight;
      found = true;
    }
    targetIndices = (targetIndices + indices.size()) / 2 / 3 * 3;
    if (target.kind == SimplifyTarget::Kind::Error) targetError *= 0.5f;
  }
  if (!found) {  // keep it closed: the input as it is, without its grid-edge keys (as documented)
    result = mesh;
    result.edgeKeys.clear();
    r.keptInput = true;
    r.watertightAfter = r.watertightBefore;
  }
  r.trianglesAfter = result.triangles.size();
  if (report) *report = r;
  return result;
}

std::string SimplifyReport::summary() const {
  char line[256];
  if (keptInput) {
    std::snprintf(line, sizeof line, "simplify: every target opened the mesh, kept the input's %zu triangles", trianglesBefore);
  } else {
    std::snprintf(line, sizeof line, "simplified %zu -> %zu triangles (%.3g %%), error %.3g %% of the extent, %s",
                  trianglesBefore, trianglesAfter,
                  trianglesBefore ? 100.0 * double(trianglesAfter) / double(trianglesBefore) : 100.0, 100.0 * double(error),
                  watertightAfter ? "still watertight" : (watertightBefore ? "NO LONGER watertight" : "open input, border locked"));
  }
  return line;
}

}  // namespace blobvk::mesh
