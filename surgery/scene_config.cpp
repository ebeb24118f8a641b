#include "blobvk/surgery/scene_config.h"

#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_json.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <set>
#include <stdexcept>

namespace blobvk::surgery {
namespace {

using Json = nlohmann::json;

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& ptr, const std::string& problem) const {
    throw blobtree::SceneError(file_, ptr, problem);
  }

  void keys(const Json& j, const std::string& ptr, std::set<std::string> allowed) const {
    if (!j.is_object()) fail(ptr, "expected an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (!allowed.count(it.key())) {
        std::string list;
        for (const auto& k : allowed) list += (list.empty() ? "" : ", ") + k;
        fail(ptr + "/" + it.key(), "unknown key \"" + it.key() + "\" (allowed: " + list + ")");
      }
    }
  }

  double number(const Json& j, const std::string& ptr, double lo, double hi) const {
    if (!j.is_number()) fail(ptr, "expected a number");
    const double v = j.get<double>();
    if (!std::isfinite(v) || v < lo || v > hi) {
      fail(ptr, "value " + j.dump() + " is outside [" + Json(lo).dump() + ", " + Json(hi).dump() + "]");
    }
    return v;
  }

  int integer(const Json& j, const std::string& ptr, int lo, int hi) const {
    if (!j.is_number_integer()) fail(ptr, "expected an integer");
    const long long v = j.get<long long>();
    if (v < lo || v > hi) fail(ptr, "value " + j.dump() + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return int(v);
  }

  mesh::Double3 vec3(const Json& j, const std::string& ptr, double limit = 1e6) const {
    if (!j.is_array() || j.size() != 3) fail(ptr, "expected an array of 3 numbers");
    return {number(j[0], ptr + "/0", -limit, limit), number(j[1], ptr + "/1", -limit, limit),
            number(j[2], ptr + "/2", -limit, limit)};
  }

  fem::Material material(const Json& j, const std::string& ptr) const {
    keys(j, ptr, {"E", "nu", "density"});
    fem::Material m;
    if (j.contains("E")) m.youngModulus = number(j["E"], ptr + "/E", 1e-6, 1e15);
    if (j.contains("nu")) m.poissonRatio = number(j["nu"], ptr + "/nu", -0.999, 0.4999);
    if (j.contains("density")) m.density = number(j["density"], ptr + "/density", 1e-6, 1e7);
    return m;
  }

  fem::Tool tool(const Json& j, const std::string& ptr) const {
    keys(j, ptr, {"shape", "radius", "halfLength", "halfExtents", "stiffness", "path"});
    fem::Tool t;
    const std::string shape = j.value("shape", "sphere");
    if (shape == "sphere") t.shape = fem::ToolShape::Sphere;
    else if (shape == "capsule") t.shape = fem::ToolShape::Capsule;
    else if (shape == "box") t.shape = fem::ToolShape::Box;
    else fail(ptr + "/shape", "unknown tool shape \"" + shape + "\" (sphere, capsule, box)");
    if (j.contains("radius")) t.radius = number(j["radius"], ptr + "/radius", 1e-9, 1e6);
    if (j.contains("halfLength")) t.halfLength = number(j["halfLength"], ptr + "/halfLength", 0, 1e6);
    // The library's own rules (fem::validateTool), found here with the file and place.
    if (j.contains("halfExtents")) {
      t.halfExtents = vec3(j["halfExtents"], ptr + "/halfExtents");
      const double e[3] = {t.halfExtents.x, t.halfExtents.y, t.halfExtents.z};
      for (int c = 0; c < 3; ++c)
        if (!(e[c] >= 0)) fail(ptr + "/halfExtents/" + std::to_string(c), "halfExtents must be >= 0, got " + Json(e[c]).dump());
    }
    if (j.contains("stiffness")) {
      t.stiffness = number(j["stiffness"], ptr + "/stiffness", 0, 1e15);
      if (!(t.stiffness > 0)) fail(ptr + "/stiffness", "stiffness must be > 0");
    }
    if (!j.contains("path")) fail(ptr, "a tool needs a \"path\" of keyframes");
    const Json& path = j["path"];
    if (!path.is_array() || path.empty()) fail(ptr + "/path", "expected a non-empty array of keyframes");
    double last = -1e300;
    for (std::size_t i = 0; i < path.size(); ++i) {
      const std::string kp = ptr + "/path/" + std::to_string(i);
      keys(path[i], kp, {"t", "position", "orientation"});
      fem::ToolKeyframe k;
      if (!path[i].contains("t") || !path[i].contains("position")) fail(kp, "a keyframe needs \"t\" and \"position\"");
      k.time = number(path[i]["t"], kp + "/t", 0, 1e9);
      if (k.time < last) fail(kp + "/t", "keyframe times must not decrease");
      last = k.time;
      k.position = vec3(path[i]["position"], kp + "/position");
      if (path[i].contains("orientation")) {
        const Json& q = path[i]["orientation"];
        if (!q.is_array() || q.size() != 4) fail(kp + "/orientation", "expected a quaternion [w, x, y, z]");
        double n2 = 0;
        for (int c = 0; c < 4; ++c) {
          k.orientation[c] = number(q[c], kp + "/orientation/" + std::to_string(c), -1e6, 1e6);
          n2 += k.orientation[c] * k.orientation[c];
        }
        if (n2 < 1e-12) fail(kp + "/orientation", "a zero quaternion is not a rotation");
        for (double& c : k.orientation) c /= std::sqrt(n2);
      }
      t.path.push_back(k);
    }
    return t;
  }

  // {"near": [x,y,z], "start": s, "path": [{"t", "translate", "rotate": {"axis", "degrees"}}]}
  LiftConfig lift(const Json& j, const std::string& ptr) const {
    keys(j, ptr, {"near", "start", "path"});
    LiftConfig l;
    if (!j.contains("near")) fail(ptr, "a lift needs \"near\": a point next to the part to lift");
    l.near = vec3(j["near"], ptr + "/near");
    if (j.contains("start")) l.start = number(j["start"], ptr + "/start", 0, 1e9);
    if (!j.contains("path")) fail(ptr, "a lift needs a \"path\" of keyframes");
    const Json& path = j["path"];
    if (!path.is_array() || path.empty()) fail(ptr + "/path", "expected a non-empty array of keyframes {t, translate, rotate}");
    double last = -1e300;
    for (std::size_t i = 0; i < path.size(); ++i) {
      const std::string kp = ptr + "/path/" + std::to_string(i);
      keys(path[i], kp, {"t", "translate", "rotate"});
      if (!path[i].contains("t")) fail(kp, "a keyframe needs \"t\" (seconds after the lift starts)");
      LiftKeyframe k;
      k.time = number(path[i]["t"], kp + "/t", 0, 1e9);
      if (k.time < last) fail(kp + "/t", "keyframe times must not decrease");
      last = k.time;
      if (path[i].contains("translate")) k.translation = vec3(path[i]["translate"], kp + "/translate");
      if (path[i].contains("rotate")) {
        const Json& r = path[i]["rotate"];
        keys(r, kp + "/rotate", {"axis", "degrees"});
        if (!r.contains("axis") || !r.contains("degrees")) fail(kp + "/rotate", "a rotation needs \"axis\" and \"degrees\"");
        const mesh::Double3 axis = vec3(r["axis"], kp + "/rotate/axis");
        const double n = std::sqrt(axis.x * axis.x + axis.y * axis.y + axis.z * axis.z);
        if (n < 1e-12) fail(kp + "/rotate/axis", "the rotation axis must not be zero");
        // The rotation since the start, blended by normalized lerp: kept below a half turn.
        const double half = 0.5 * number(r["degrees"], kp + "/rotate/degrees", -179, 179) * 3.14159265358979323846 / 180;
        k.rotation = {std::cos(half), std::sin(half) * axis.x / n, std::sin(half) * axis.y / n, std::sin(half) * axis.z / n};
      }
      l.path.push_back(k);
    }
    return l;
  }

  std::string file_;
};

// A BlobTree node inside the simulation section, read with the scene reader's own rules.
blobtree::Program selector(const Json& j, const std::string& ptr, const std::string& file) {
  const std::string text = Json{{"blobvk", 1}, {"root", j}}.dump();
  try {
    return blobtree::compile(blobtree::parseSceneJson(text, file).root);
  } catch (const blobtree::SceneError& e) {
    std::string location = e.location();
    if (location.rfind("/root", 0) == 0) location = ptr + location.substr(5);
    throw blobtree::SceneError(file, location, e.problem());
  }
}

}  // namespace

namespace {
// A blade path at `ptr`: at least two keyframes {t, a, b}, times increasing strictly (the
// scripted procedure sweeps between consecutive ones).
std::vector<BladeKeyframe> readBlade(const Reader& r, const Json& b, const std::string& ptr) {
  if (!b.is_array() || b.size() < 2) r.fail(ptr, "expected an array of at least 2 keyframes {t, a, b}");
  std::vector<BladeKeyframe> blade;
  double last = -1e300;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const std::string kp = ptr + "/" + std::to_string(i);
    r.keys(b[i], kp, {"t", "a", "b"});
    if (!b[i].contains("t") || !b[i].contains("a") || !b[i].contains("b")) r.fail(kp, "a blade keyframe needs \"t\", \"a\" and \"b\"");
    BladeKeyframe k{r.number(b[i]["t"], kp + "/t", 0, 1e9), r.vec3(b[i]["a"], kp + "/a"), r.vec3(b[i]["b"], kp + "/b")};
    if (k.time <= last) r.fail(kp + "/t", "keyframe times must increase strictly");
    last = k.time;
    blade.push_back(k);
  }
  return blade;
}
}  // namespace

std::vector<BladeKeyframe> parseBladePath(const std::string& text, const std::string& file) {
  Reader r(file);
  blobtree::refuseDuplicateKeys(text, file);
  Json j;
  try {
    j = Json::parse(text);
  } catch (const Json::exception& e) {
    throw blobtree::malformedJson(e, text, file);
  }
  if (!j.is_object()) r.fail("/", "expected an object with a \"blade\" array");
  r.keys(j, "", {"blade"});
  if (!j.contains("blade")) r.fail("/blade", "missing: the blade path, an array of keyframes {t, a, b}");
  return readBlade(r, j["blade"], "/blade");
}

SimulationConfig parseSimulationConfig(const std::string& text, const std::string& file) {
  Reader r(file);
  SimulationConfig c;
  const std::string p = "/simulation";
  Json j;
  try {
    j = Json::parse(text);
  } catch (const std::exception&) {
    r.fail(p, "malformed JSON");
  }
  r.keys(j, p, {"mesher", "tetgen", "voxel", "materials", "materialFromPrimitive", "timeStep",
                "gravity", "damping", "solver", "fixed", "floor", "tools", "blade", "lift", "steps",
                "frameEvery"});
  if (j.contains("mesher")) {
    c.mesher = j["mesher"].is_string() ? j["mesher"].get<std::string>() : "";
    if (c.mesher != "voxel" && c.mesher != "tetgen") r.fail(p + "/mesher", "expected \"voxel\" or \"tetgen\"");
  }
  if (j.contains("tetgen")) {
    const Json& t = j["tetgen"];
    r.keys(t, p + "/tetgen", {"radiusEdge", "minDihedral", "maxVolume", "maxAddedPoints", "keepSurface", "optimizeMaxDihedral",
                                   "remeshEdge", "smoothSlivers"});
    if (t.contains("remeshEdge")) c.tetgenRemeshEdgeCells = r.number(t["remeshEdge"], p + "/tetgen/remeshEdge", 0, 100);
    if (t.contains("radiusEdge")) c.tetgen.maxRadiusEdgeRatio = r.number(t["radiusEdge"], p + "/tetgen/radiusEdge", 1.0, 100);
    if (t.contains("minDihedral")) c.tetgen.minDihedralDegrees = r.number(t["minDihedral"], p + "/tetgen/minDihedral", 0, 30);
    if (t.contains("optimizeMaxDihedral"))
      c.tetgen.optimizeMaxDihedralDegrees = r.number(t["optimizeMaxDihedral"], p + "/tetgen/optimizeMaxDihedral", 0, 180);
    if (t.contains("maxVolume")) c.tetgen.maxVolume = r.number(t["maxVolume"], p + "/tetgen/maxVolume", 0, 1e12);
    if (t.contains("maxAddedPoints"))
      c.tetgen.maxAddedPoints = std::uint32_t(r.integer(t["maxAddedPoints"], p + "/tetgen/maxAddedPoints", 0, 100000000));
    if (t.contains("keepSurface")) {
      if (!t["keepSurface"].is_boolean()) r.fail(p + "/tetgen/keepSurface", "expected true or false");
      c.tetgen.keepSurface = t["keepSurface"].get<bool>();
    }
    if (t.contains("smoothSlivers")) {
      if (!t["smoothSlivers"].is_boolean()) r.fail(p + "/tetgen/smoothSlivers", "expected true or false");
      c.tetgen.smoothSlivers = t["smoothSlivers"].get<bool>();
    }
  }
  if (j.contains("voxel")) {
    r.keys(j["voxel"], p + "/voxel", {"cellSize"});
    if (j["voxel"].contains("cellSize")) c.voxelCellSize = r.number(j["voxel"]["cellSize"], p + "/voxel/cellSize", 1e-6, 1e6);
  }
  if (j.contains("materials")) {
    const Json& m = j["materials"];
    if (!m.is_array() || m.empty()) r.fail(p + "/materials", "expected a non-empty array of materials");
    c.settings.materials.clear();
    for (std::size_t i = 0; i < m.size(); ++i) c.settings.materials.push_back(r.material(m[i], p + "/materials/" + std::to_string(i)));
  }
  if (j.contains("materialFromPrimitive")) {
    if (!j["materialFromPrimitive"].is_boolean()) r.fail(p + "/materialFromPrimitive", "expected true or false");
    c.materialFromPrimitive = j["materialFromPrimitive"].get<bool>();
  }
  if (j.contains("timeStep")) c.settings.timeStep = r.number(j["timeStep"], p + "/timeStep", 1e-7, 10);
  if (j.contains("gravity")) c.settings.gravity = r.vec3(j["gravity"], p + "/gravity", 1e4);
  if (j.contains("damping")) {
    r.keys(j["damping"], p + "/damping", {"mass", "stiffness"});
    if (j["damping"].contains("mass")) c.settings.rayleighMass = r.number(j["damping"]["mass"], p + "/damping/mass", 0, 1e6);
    if (j["damping"].contains("stiffness")) c.settings.rayleighStiffness = r.number(j["damping"]["stiffness"], p + "/damping/stiffness", 0, 1e6);
  }
  if (j.contains("solver")) {
    r.keys(j["solver"], p + "/solver", {"maxIterations", "tolerance", "preconditioner", "coarseAggregateNodes"});
    if (j["solver"].contains("preconditioner")) {
      const Json& v = j["solver"]["preconditioner"];
      const std::string name = v.is_string() ? v.get<std::string>() : "";
      if (name == "jacobi") c.settings.preconditioner = fem::PreconditionerKind::Jacobi;
      else if (name == "blockJacobi") c.settings.preconditioner = fem::PreconditionerKind::BlockJacobi;
      else if (name == "incompleteCholesky") c.settings.preconditioner = fem::PreconditionerKind::IncompleteCholesky;
      else r.fail(p + "/solver/preconditioner", "expected \"jacobi\", \"blockJacobi\" or \"incompleteCholesky\", got " + v.dump());
    }
    if (j["solver"].contains("maxIterations")) c.settings.cgMaxIterations = r.integer(j["solver"]["maxIterations"], p + "/solver/maxIterations", 1, 100000);
    if (j["solver"].contains("tolerance")) c.settings.cgTolerance = r.number(j["solver"]["tolerance"], p + "/solver/tolerance", 0, 1);
    if (j["solver"].contains("coarseAggregateNodes"))
      c.settings.coarseAggregateNodes = r.integer(j["solver"]["coarseAggregateNodes"], p + "/solver/coarseAggregateNodes", 0, 1000000);
  }
  if (j.contains("fixed")) c.fixedSelector = selector(j["fixed"], p + "/fixed", file);
  if (j.contains("floor")) {
    const Json& f = j["floor"];
    r.keys(f, p + "/floor", {"normal", "offset", "restitution", "friction"});
    fem::FloorPlane floor;
    if (f.contains("normal")) floor.normal = r.vec3(f["normal"], p + "/floor/normal");
    const double n = std::sqrt(floor.normal.x * floor.normal.x + floor.normal.y * floor.normal.y + floor.normal.z * floor.normal.z);
    if (n < 1e-12) r.fail(p + "/floor/normal", "the floor normal must not be zero");
    floor.normal = {floor.normal.x / n, floor.normal.y / n, floor.normal.z / n};
    if (f.contains("offset")) floor.offset = r.number(f["offset"], p + "/floor/offset", -1e6, 1e6);
    if (f.contains("restitution")) floor.restitution = r.number(f["restitution"], p + "/floor/restitution", 0, 1);
    if (f.contains("friction")) floor.friction = r.number(f["friction"], p + "/floor/friction", 0, 1);
    c.settings.floor = floor;
  }
  if (j.contains("tools")) {
    const Json& t = j["tools"];
    if (!t.is_array()) r.fail(p + "/tools", "expected an array of tools");
    for (std::size_t i = 0; i < t.size(); ++i) c.settings.tools.push_back(r.tool(t[i], p + "/tools/" + std::to_string(i)));
  }
  if (j.contains("blade")) c.blade = readBlade(r, j["blade"], p + "/blade");
  if (j.contains("lift")) c.lift = r.lift(j["lift"], p + "/lift");
  if (j.contains("steps")) c.steps = r.integer(j["steps"], p + "/steps", 1, 10000000);
  if (j.contains("frameEvery")) c.frameEvery = r.integer(j["frameEvery"], p + "/frameEvery", 1, 1000000);
  return c;
}

}  // namespace blobvk::surgery
