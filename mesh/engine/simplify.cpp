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
#include <optional>
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

// One simplifier run to at most `targetTriangles` (0: as few as the error bound allows), with the
// fin pairs removed. `closed` is the guard's test, and it asks for the same surface topology too:
// watertight, the same Euler characteristic and components (a collapse that shuts a window of the
// tower is not the same model).
struct Try {
  TriMesh mesh;
  float error = 0.0f;
  std::size_t reached = 0;  // the simplifier's triangles, before the fins are dropped
  bool closed = false;
};

Try simplifyOnce(const TriMesh& mesh, const std::vector<unsigned>& indices, const MeshReport& before,
                 std::size_t targetTriangles, float targetError, unsigned options) {
  Try t;
  std::vector<unsigned> out(indices.size());
  const std::size_t count = meshopt_simplify(out.data(), indices.data(), indices.size(), &mesh.positions[0].x,
                                             mesh.positions.size(), sizeof(Float3), 3 * targetTriangles, targetError,
                                             options, &t.error);
  out.resize(count);
  t.reached = count / 3;
  dropFinPairs(out);
  t.mesh = packMesh(mesh, out);
  const MeshReport after = checkMesh(t.mesh);
  t.closed = after.watertight() && after.eulerCharacteristic == before.eulerCharacteristic &&
             after.components == before.components;
  return t;
}

// Above a triangle target that opened the mesh (`failed`), the smallest target found that keeps it
// closed; the input's count (`total`) is closed, as the simplifier changes nothing there. Empty
// when no target below `total` was closed.
//
// Closedness is not monotone in the target (4 triangles close a die that 2 or 150 do not), so no
// search finds the smallest closed target for sure; this one backs off gradually and keeps the
// result monotone in the request. The targets it tries lie on a lattice fixed by the mesh alone:
// doublings from the fewest triangles a closed surface can have, then a bisection of the octave
// where the first closed doubling lies, down to 1/32 of it. A target at or below `failed` counts
// as open without a run: the error bound stops the simplifier there anyway (and a ratio asked for
// no fewer). Above it, a target's result hardly depends on the error bound (the count stops the
// simplifier first), so a looser request only turns more lattice points into candidates, and a
// bisection over a fixed lattice never ends higher when more of its points are candidates: of two
// requests that back off, the looser does not get more triangles. A tighter request whose first
// try closed is not on the lattice, so a looser one that backs off can end a little above it (the
// tower at 96: 1 % closes at 1384 triangles, 2 % backs off to 1536). About log2(total / failed) + 5
// runs.
std::optional<Try> backOff(const TriMesh& mesh, const std::vector<unsigned>& indices, const MeshReport& before,
                           std::size_t failed, std::size_t total, float targetError, unsigned options, int& attempts) {
  std::optional<Try> best;
  auto closedAt = [&](std::size_t target) {
    if (target <= failed) return false;
    ++attempts;
    Try t = simplifyOnce(mesh, indices, before, target, targetError, options);
    if (!t.closed) return false;
    best = std::move(t);  // the targets that close it only go down from here
    return true;
  };
  // A closed surface has at least a tetrahedron's 4 triangles per component.
  const std::size_t fewest = 4 * std::max<std::size_t>(before.components, 1);
  std::size_t hi = fewest;
  while (hi < total && !closedAt(hi)) hi *= 2;
  if (!best) return best;
  std::size_t lo = hi == fewest ? hi - 1 : hi / 2;  // the doubling below was open (or not a surface)
  const std::size_t step = std::max<std::size_t>(1, hi / 32);
  while (hi - lo > step) {
    const std::size_t mid = lo + (hi - lo) / 2;
    (closedAt(mid) ? hi : lo) = mid;
  }
  return best;
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
  // An error target asks for as few triangles as that error allows (target 0); a ratio has no
  // error bound. Backing off keeps the error bound: a gentler result must still be within it.
  std::size_t targetTriangles = 0;
  float targetError = std::numeric_limits<float>::max();
  if (target.kind == SimplifyTarget::Kind::Ratio)
    targetTriangles = std::size_t(std::llround(double(target.value) * double(mesh.triangles.size())));
  else
    targetError = target.value;

  r.attempts = 1;
  Try first = simplifyOnce(mesh, indices, before, targetTriangles, targetError, options);
  r.trianglesFirstTry = first.reached;
  std::optional<Try> chosen;
  if (first.closed || !r.watertightBefore) {  // an open input has no closedness to lose
    chosen = std::move(first);
  } else {
    // Edge collapses can pinch a thin part into a non-manifold edge, or shrink a part to nothing:
    // fewer collapses avoid that, so look for the smallest count above the failing one that is closed.
    r.backedOff = true;
    chosen = backOff(mesh, indices, before, std::max(first.reached, targetTriangles), mesh.triangles.size(),
                     targetError, options, r.attempts);
  }
  TriMesh result;
  if (chosen) {
    result = std::move(chosen->mesh);
    r.error = chosen->error;
    r.watertightAfter = chosen->closed;
  } else {  // keep it closed: the input as it is, without its grid-edge keys (as documented)
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
  char line[384];
  if (keptInput) {
    std::snprintf(line, sizeof line, "simplify: every target opened the mesh, kept the input's %zu triangles", trianglesBefore);
    return line;
  }
  int n = std::snprintf(line, sizeof line, "simplified %zu -> %zu triangles (%.3g %%), error %.3g %% of the extent, %s",
                        trianglesBefore, trianglesAfter,
                        trianglesBefore ? 100.0 * double(trianglesAfter) / double(trianglesBefore) : 100.0,
                        100.0 * double(error),
                        watertightAfter ? "still watertight"
                                        : (watertightBefore ? "NO LONGER watertight" : "open input, border locked"));
  // More triangles than were asked for is worth a word: the target was not met, and why.
  if (backedOff && n > 0 && std::size_t(n) < sizeof line)
    std::snprintf(line + n, sizeof line - std::size_t(n), " (backed off: the target's %zu triangles were not closed)",
                  trianglesFirstTry);
  return line;
}

}  // namespace blobvk::mesh
