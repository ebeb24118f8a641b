// Writer of the JSON scene format: explicit about every parameter, silent about defaults, and
// laid out for people (short arrays and small objects on one line, trees indented).
#include "blobvk/blobtree/scene_instance.h"
#include "blobvk/blobtree/scene_json.h"

#include <nlohmann/json.hpp>

#include <stdexcept>

namespace blobvk::blobtree {
namespace {

using Json = nlohmann::ordered_json;

Json array(const Vec3& v) { return Json::array({v.x, v.y, v.z}); }

const char* axisName(int axis) {
  if (axis < 0 || axis > 2) throw std::invalid_argument("writeSceneJson: warp axis " + std::to_string(axis) + " is not 0, 1 or 2");
  return axis == 0 ? "x" : axis == 1 ? "y" : "z";
}

// "x"/"y"/"z" for a unit axis, else the vector.
Json direction(const Vec3& d) {
  for (int i = 0; i < 3; ++i) {
    Vec3 unit(0.0);
    unit[i] = 1.0;
    if (d == unit) return axisName(i);
  }
  return array(d);
}

// The JSON type names are the toString() names of tree.h.
const char* typeName(const Node& n) {
  if (const auto* p = std::get_if<Primitive>(&n.kind)) return toString(p->type);
  if (const auto* o = std::get_if<Operator>(&n.kind)) return toString(o->type);
  return toString(std::get<Warp>(n.kind).type);
}

Json transform(const Transform& t) {
  Json j = Json::object();
  if (t.translate != Vec3(0.0)) j["translate"] = array(t.translate);
  if (t.rotate != Quat(1.0, 0.0, 0.0, 0.0))
    j["rotate"] = {{"quaternion", Json::array({t.rotate.x, t.rotate.y, t.rotate.z, t.rotate.w})}};
  if (t.scale != Vec3(1.0)) {
    if (t.scale.x == t.scale.y && t.scale.y == t.scale.z) j["scale"] = t.scale.x;
    else j["scale"] = array(t.scale);
  }
  return j;
}

void primitive(const Primitive& p, Json& j) {
  switch (p.type) {
    case PrimitiveType::Point: j["centre"] = array(p.a); break;
    case PrimitiveType::Line:
      j["start"] = array(p.a);
      j["end"] = array(p.b);
      break;
    case PrimitiveType::Cylinder:
      j["base"] = array(p.a);
      j["axis"] = direction(p.b);
      j["radius"] = p.radius;
      j["height"] = p.height;
      break;
    case PrimitiveType::Disc:
    case PrimitiveType::Ring:
      j["centre"] = array(p.a);
      j["normal"] = direction(p.b);
      j["radius"] = p.radius;
      break;
    case PrimitiveType::Cube:
      j["centre"] = array(p.a);
      if (p.b.x == p.b.y && p.b.y == p.b.z) j["halfExtents"] = p.b.x;
      else j["halfExtents"] = array(p.b);
      break;
    case PrimitiveType::Triangle: j["corners"] = Json::array({array(p.a), array(p.b), array(p.c)}); break;
    case PrimitiveType::QuadricPoint:
      j["centre"] = array(p.a);
      j["scale"] = p.scale;
      break;
  }
  if (p.support != 1.0) j["support"] = p.support;
  if (p.colour != Primitive{}.colour) j["colour"] = array(p.colour);
}

void warp(const Warp& w, Json& j) {
  switch (w.type) {
    case WarpType::Twist:
      j["axis"] = axisName(w.axis);
      j["factor"] = w.factor;
      break;
    case WarpType::Taper:
      j["axis"] = axisName(w.axis);
      j["taperAxis"] = axisName(w.otherAxis);
      j["factor"] = w.factor;
      break;
    case WarpType::Bend:
      j["axis"] = axisName(w.axis);
      j["towards"] = axisName(w.otherAxis);
      j["rate"] = w.factor;
      j["centre"] = w.centre;
      if (w.lo != Warp{}.lo) j["lo"] = w.lo;
      if (w.hi != Warp{}.hi) j["hi"] = w.hi;
      break;
    case WarpType::Shear:
      j["axis"] = axisName(w.axis);
      j["by"] = axisName(w.otherAxis);
      j["factor"] = w.factor;
      break;
  }
}

Json node(const Node& n) {
  Json j = Json::object();
  j["type"] = typeName(n);
  if (!n.id.empty()) j["id"] = n.id;
  if (!detail::isIdentityTransform(n.transform)) j["transform"] = transform(n.transform);
  if (const auto* p = std::get_if<Primitive>(&n.kind)) {
    primitive(*p, j);
    return j;
  }
  if (const auto* o = std::get_if<Operator>(&n.kind)) {
    if (o->type == OperatorType::Ricci) j["power"] = o->power;
  } else {
    warp(std::get<Warp>(n.kind), j);
  }
  Json kids = Json::array();
  for (const Node& c : n.children) kids.push_back(node(c));
  j["children"] = std::move(kids);
  return j;
}

// ---- layout ----------------------------------------------------------------------------------

constexpr std::size_t kLineWidth = 100;

bool holdsChildren(const Json& j) {
  return j.is_object() && (j.contains("children") || j.contains("root"));
}

std::string compact(const Json& j) {
  if (j.is_array()) {
    std::string s = "[";
    for (std::size_t i = 0; i < j.size(); ++i) s += (i ? ", " : "") + compact(j[i]);
    return s + "]";
  }
  if (j.is_object()) {
    std::string s = "{";
    bool first = true;
    for (const auto& item : j.items()) {
      s += (first ? "" : ", ") + Json(item.key()).dump() + ": " + compact(item.value());
      first = false;
    }
    return s + "}";
  }
  return j.dump();
}

void pretty(const Json& j, std::size_t indent, std::string& out) {
  if (!holdsChildren(j)) {
    std::string line = compact(j);
    if (line.size() + indent <= kLineWidth || !(j.is_object() || j.is_array())) {
      out += line;
      return;
    }
  }
  const std::string pad(indent + 2, ' ');
  if (j.is_array()) {
    out += "[\n";
    for (std::size_t i = 0; i < j.size(); ++i) {
      out += pad;
      pretty(j[i], indent + 2, out);
      out += i + 1 < j.size() ? ",\n" : "\n";
    }
    out += std::string(indent, ' ') + "]";
    return;
  }
  out += "{\n";
  std::size_t i = 0;
  for (const auto& item : j.items()) {
    out += pad + Json(item.key()).dump() + ": ";
    pretty(item.value(), indent + 2, out);
    out += ++i < j.size() ? ",\n" : "\n";
  }
  out += std::string(indent, ' ') + "}";
}

}  // namespace

std::string writeSceneJson(const Scene& scene) {
  Json doc = Json::object();
  doc["blobvk"] = 1;
  if (!scene.name.empty()) doc["name"] = scene.name;
  if (scene.camera) {
    const Camera& c = *scene.camera;
    Json cam = Json::object();
    if (c.eye) cam["eye"] = array(*c.eye);
    if (c.target) cam["target"] = array(*c.target);
    if (c.up) cam["up"] = array(*c.up);
    if (c.azimuthDeg) cam["azimuthDeg"] = *c.azimuthDeg;
    if (c.elevationDeg) cam["elevationDeg"] = *c.elevationDeg;
    if (c.distance) cam["distance"] = *c.distance;
    cam["fovYDeg"] = c.fovYDeg;
    doc["camera"] = std::move(cam);
  }
  const GridSettings& g = scene.grid;
  if (g.cellSize || g.resolution || g.boundsLo || g.boundsHi) {
    Json grid = Json::object();
    if (g.cellSize) grid["cellSize"] = *g.cellSize;
    if (g.resolution) grid["resolution"] = *g.resolution;
    if (g.boundsLo && g.boundsHi) grid["bounds"] = {{"lo", array(*g.boundsLo)}, {"hi", array(*g.boundsHi)}};
    doc["grid"] = std::move(grid);
  }
  if (!scene.simulationJson.empty()) {
    try {
      doc["simulation"] = Json::parse(scene.simulationJson);
    } catch (const Json::exception& e) {
      throw std::invalid_argument(std::string("writeSceneJson: simulationJson is not JSON: ") + e.what());
    }
  }
  doc["root"] = node(scene.root);
  std::string out;
  pretty(doc, 0, out);
  return out + "\n";
}

}  // namespace blobvk::blobtree
