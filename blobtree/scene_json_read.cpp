// Strict reader of the JSON scene format. Every value is checked where it is read, and every
// failure names the JSON pointer of the offending value; see docs/scene-format.md.
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_instance.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/blobtree/scene_limits.h"
#include "blobvk/blobtree/scene_text.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace blobvk::blobtree {
namespace {

using Json = nlohmann::ordered_json;
using detail::quotedText;

// RFC 6901 escaping of one reference token.
std::string pointerToken(std::string_view key) {
  std::string out;
  for (char c : key) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

// A JSON pointer as a chain of stack-allocated links: nothing is built per node while reading,
// the string is made only for an error message (deep trees would otherwise cost O(depth^2)).
struct Ptr {
  const Ptr* parent = nullptr;
  const std::string* base = nullptr;  // a whole pointer this one starts from (instance targets)
  std::string_view key;
  std::size_t index = 0;
  bool isIndex = false;

  std::string str() const {
    std::vector<const Ptr*> chain;
    for (const Ptr* p = this; p; p = p->parent) chain.push_back(p);
    std::string out;
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const Ptr& p = **it;
      if (p.base) out += *p.base;
      if (p.isIndex) out += "/" + std::to_string(p.index);
      else if (p.parent || !p.key.empty()) out += "/" + pointerToken(p.key);
    }
    return out;
  }
};

Ptr child(const Ptr& parent, std::string_view key) { return Ptr{&parent, nullptr, key, 0, false}; }
Ptr child(const Ptr& parent, std::size_t index) { return Ptr{&parent, nullptr, {}, index, true}; }

// Pointers into very deep trees are cut in the middle so the message stays readable, and
// control characters from keys are escaped so the message stays on one line.
std::string shortened(const std::string& pointer) {
  std::string safe;
  for (char ch : pointer) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      safe += buf;
    } else {
      safe += ch;
    }
  }
  if (safe.size() <= 240) return safe;
  return safe.substr(0, 100) + "/..." + safe.substr(safe.size() - 100);
}

enum class Category { Primitive, Operator, Warp, Instance };

struct TypeInfo {
  std::string_view name;
  Category category;
  int code;  // PrimitiveType, OperatorType or WarpType value
};

constexpr TypeInfo kTypes[] = {
    {"point", Category::Primitive, int(PrimitiveType::Point)},
    {"line", Category::Primitive, int(PrimitiveType::Line)},
    {"cylinder", Category::Primitive, int(PrimitiveType::Cylinder)},
    {"disc", Category::Primitive, int(PrimitiveType::Disc)},
    {"ring", Category::Primitive, int(PrimitiveType::Ring)},
    {"cube", Category::Primitive, int(PrimitiveType::Cube)},
    {"triangle", Category::Primitive, int(PrimitiveType::Triangle)},
    {"quadricPoint", Category::Primitive, int(PrimitiveType::QuadricPoint)},
    {"blend", Category::Operator, int(OperatorType::Blend)},
    {"ricci", Category::Operator, int(OperatorType::Ricci)},
    {"union", Category::Operator, int(OperatorType::Union)},
    {"intersection", Category::Operator, int(OperatorType::Intersection)},
    {"difference", Category::Operator, int(OperatorType::Difference)},
    {"smoothDifference", Category::Operator, int(OperatorType::SmoothDifference)},
    {"twist", Category::Warp, int(WarpType::Twist)},
    {"taper", Category::Warp, int(WarpType::Taper)},
    {"bend", Category::Warp, int(WarpType::Bend)},
    {"shear", Category::Warp, int(WarpType::Shear)},
    {"instance", Category::Instance, 0},
};

const TypeInfo* findType(std::string_view name) {
  for (const TypeInfo& t : kTypes)
    if (t.name == name) return &t;
  return nullptr;
}

std::string typeList() {
  std::string out;
  for (const TypeInfo& t : kTypes) out += (out.empty() ? "" : ", ") + std::string(t.name);
  return out;
}

// Keys a node of each type accepts, beyond "type", "id" and "transform".
std::vector<std::string_view> extraKeys(const TypeInfo& t) {
  switch (t.category) {
    case Category::Instance: return {"of"};
    case Category::Operator:
      if (t.code == int(OperatorType::Ricci)) return {"children", "power"};
      return {"children"};
    case Category::Warp:
      switch (WarpType(t.code)) {
        case WarpType::Twist: return {"children", "axis", "factor"};
        case WarpType::Taper: return {"children", "axis", "taperAxis", "factor"};
        case WarpType::Bend: return {"children", "axis", "towards", "rate", "centre", "lo", "hi"};
        case WarpType::Shear: return {"children", "axis", "by", "factor"};
      }
      return {};
    case Category::Primitive:
      switch (PrimitiveType(t.code)) {
        case PrimitiveType::Point: return {"colour", "support", "centre"};
        case PrimitiveType::Line: return {"colour", "support", "start", "end"};
        case PrimitiveType::Cylinder:
          return {"colour", "support", "base", "axis", "radius", "height"};
        case PrimitiveType::Disc:
        case PrimitiveType::Ring: return {"colour", "support", "centre", "normal", "radius"};
        case PrimitiveType::Cube: return {"colour", "support", "centre", "halfExtents"};
        case PrimitiveType::Triangle: return {"colour", "support", "corners"};
        case PrimitiveType::QuadricPoint: return {"colour", "support", "centre", "scale"};
      }
  }
  return {};
}

// Common misspellings get a hint in the "unknown key" message, where the key meant is one the
// object takes (`center` on a line, which has no centre, gets none).
std::string hintFor(std::string_view key, const std::function<bool(std::string_view)>& allowed) {
  static const std::map<std::string_view, std::string_view> hints = {
      {"color", "colour"},     {"center", "centre"},     {"child", "children"},
      {"radii", "radius"},     {"pos", "centre"},        {"position", "centre"},
      {"halfSize", "halfExtents"}, {"size", "halfExtents"}, {"translation", "translate"},
      {"rotation", "rotate"},  {"exponent", "power"},    {"version", "blobvk"}};
  const auto it = hints.find(key);
  return it == hints.end() || !allowed(it->second) ? "" : " (did you mean '" + std::string(it->second) + "'?)";
}

class Reader {
 public:
  explicit Reader(const std::string& source) : source_(source) {}

  Scene read(const Json& doc) {
    const Ptr top;
    if (!doc.is_object()) fail(top, "expected the scene object at the top level, got " + typeOf(doc));
    checkKeys(doc, top, {"blobvk", "name", "root", "definitions", "camera", "grid", "simulation"});
    const Json& version = required(doc, top, "blobvk");
    if (!version.is_number_integer() || version.get<std::int64_t>() != 1)
      fail(child(top, "blobvk"), "unsupported format version " + version.dump() +
                                     " (this reader understands \"blobvk\": 1)");
    Scene scene;
    if (doc.contains("name")) scene.name = string(doc["name"], child(top, "name"));
    indexIds(doc);
    readDefinitions(doc);
    scene.root = node(required(doc, top, "root"), child(top, "root"), 1);
    if (doc.contains("camera")) scene.camera = camera(doc["camera"], child(top, "camera"));
    if (doc.contains("grid")) scene.grid = grid(doc["grid"], child(top, "grid"));
    if (doc.contains("simulation")) {  // validated by the simulation code, not here
      const Json& sim = doc["simulation"];
      if (!sim.is_object()) fail(child(top, "simulation"), "expected an object, got " + typeOf(sim));
      scene.simulationJson = sim.dump();
    }
    return scene;
  }

 private:
  [[noreturn]] void fail(const Ptr& pointer, const std::string& problem) const {
    const std::string text = pointer.str();
    throw SceneError(source_, shortened(text.empty() ? "/" : text), problem);
  }

  static std::string typeOf(const Json& j) {
    if (j.is_number()) return "a number";
    if (j.is_string()) return "a string";
    if (j.is_boolean()) return "a boolean";
    if (j.is_null()) return "null";
    if (j.is_array()) return "an array";
    return "an object";
  }

  [[gnu::noinline]] void checkKeys(const Json& obj, const Ptr& ptr,
                 std::initializer_list<std::string_view> allowed,
                 const std::vector<std::string_view>& more = {}) const {
    const auto takes = [&](std::string_view k) {
      return std::find(allowed.begin(), allowed.end(), k) != allowed.end() ||
             std::find(more.begin(), more.end(), k) != more.end();
    };
    for (const auto& item : obj.items()) {
      const std::string& key = item.key();
      if (!takes(key)) {
        std::string list;
        for (auto k : allowed) list += (list.empty() ? "" : ", ") + std::string(k);
        for (auto k : more) list += ", " + std::string(k);
        fail(child(ptr, key), "unknown key " + quotedText(key) + hintFor(key, takes) + " (allowed: " + list + ")");
      }
    }
  }

  const Json& required(const Json& obj, const Ptr& ptr, std::string_view key) const {
    const auto it = obj.find(key);
    if (it == obj.end()) fail(ptr, "missing required key '" + std::string(key) + "'");
    return *it;
  }

  std::string string(const Json& j, const Ptr& ptr) const {
    if (!j.is_string()) fail(ptr, "expected a string, got " + typeOf(j));
    return j.get<std::string>();
  }

  double number(const Json& j, const Ptr& ptr) const {
    if (!j.is_number()) fail(ptr, "expected a number, got " + typeOf(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(ptr, "number is not finite");
    if (std::abs(v) > limits::kMaxAbsValue)
      fail(ptr, "value " + detail::number(v) + " is out of range (|x| must be <= 1e6)");
    return v;
  }

  double positive(const Json& j, const Ptr& ptr, std::string_view what) const {
    const double v = number(j, ptr);
    if (!(v > 0.0)) fail(ptr, std::string(what) + " must be > 0, got " + detail::number(v));
    return v;
  }

  double optionalPositive(const Json& obj, const Ptr& ptr, std::string_view key,
                          double fallback) const {
    return obj.contains(key) ? positive(obj[key], child(ptr, key), key) : fallback;
  }

  std::vector<double> numbers(const Json& j, const Ptr& ptr, std::size_t count) const {
    if (!j.is_array()) fail(ptr, "expected an array of " + std::to_string(count) + " numbers, got " + typeOf(j));
    if (j.size() != count)
      fail(ptr, "expected an array of " + std::to_string(count) + " numbers, got " +
                    std::to_string(j.size()) + " elements");
    std::vector<double> out;
    for (std::size_t i = 0; i < count; ++i) out.push_back(number(j[i], child(ptr, i)));
    return out;
  }

  Vec3 vec3(const Json& j, const Ptr& ptr) const {
    const auto v = numbers(j, ptr, 3);
    return Vec3(v[0], v[1], v[2]);
  }

  Vec3 optionalVec3(const Json& obj, const Ptr& ptr, std::string_view key, Vec3 fallback) const {
    return obj.contains(key) ? vec3(obj[key], child(ptr, key)) : fallback;
  }

  int axis(const Json& j, const Ptr& ptr) const {
    if (!j.is_string()) fail(ptr, "expected an axis \"x\", \"y\" or \"z\", got " + typeOf(j));
    const std::string s = j.get<std::string>();
    if (s == "x") return 0;
    if (s == "y") return 1;
    if (s == "z") return 2;
    fail(ptr, "unknown axis " + quotedText(s) + " (expected \"x\", \"y\" or \"z\")");
  }

  int optionalAxis(const Json& obj, const Ptr& ptr, std::string_view key, int fallback) const {
    return obj.contains(key) ? axis(obj[key], child(ptr, key)) : fallback;
  }

  // A unit direction given as "x"/"y"/"z" or as a vector that is normalised here.
  Vec3 direction(const Json& j, const Ptr& ptr) const {
    if (j.is_string()) {
      Vec3 d(0.0);
      d[axis(j, ptr)] = 1.0;
      return d;
    }
    const Vec3 v = vec3(j, ptr);
    const double len = glm::length(v);
    if (!(len > 1e-9)) fail(ptr, "direction cannot be normalised (zero length)");
    return v / len;
  }

  Vec3 optionalDirection(const Json& obj, const Ptr& ptr, std::string_view key, int fallbackAxis) const {
    if (obj.contains(key)) return direction(obj[key], child(ptr, key));
    Vec3 d(0.0);
    d[fallbackAxis] = 1.0;
    return d;
  }

  Vec3 colour(const Json& j, const Ptr& ptr) const {
    const Vec3 c = vec3(j, ptr);
    for (int i = 0; i < 3; ++i)
      if (c[i] < 0.0 || c[i] > 1.0)
        fail(child(ptr, std::size_t(i)), "colour components must be within [0, 1], got " + detail::number(c[i]));
    return c;
  }

  [[gnu::noinline]] Transform transform(const Json& j, const Ptr& ptr) const {
    if (!j.is_object()) fail(ptr, "expected a transform object, got " + typeOf(j));
    checkKeys(j, ptr, {"translate", "rotate", "scale"});
    Transform t;
    t.translate = optionalVec3(j, ptr, "translate", Vec3(0.0));
    if (j.contains("rotate")) t.rotate = rotation(j["rotate"], child(ptr, "rotate"));
    if (j.contains("scale")) {
      const Json& s = j["scale"];
      const Ptr sp = child(ptr, "scale");
      if (s.is_number()) {
        t.scale = Vec3(positive(s, sp, "scale"));
      } else {
        t.scale = vec3(s, sp);
        for (int i = 0; i < 3; ++i)
          if (!(t.scale[i] > 0.0))
            fail(child(sp, std::size_t(i)), "scale must be > 0, got " + detail::number(t.scale[i]));
      }
    }
    return t;
  }

  [[gnu::noinline]] Quat rotation(const Json& j, const Ptr& ptr) const {
    if (!j.is_object())
      fail(ptr, "expected {\"quaternion\": [x, y, z, w]} or {\"axis\": ..., \"angleDeg\": ...}, got " + typeOf(j));
    checkKeys(j, ptr, {"quaternion", "axis", "angleDeg"});
    if (j.contains("quaternion")) {
      if (j.contains("axis") || j.contains("angleDeg"))
        fail(ptr, "give either \"quaternion\" or \"axis\" with \"angleDeg\", not both");
      const Ptr qp = child(ptr, "quaternion");
      const auto q = numbers(j["quaternion"], qp, 4);
      Quat r(q[3], q[0], q[1], q[2]);
      const double len2 = glm::dot(r, r);
      if (!(len2 > 1e-18)) fail(qp, "quaternion cannot be normalised (zero length)");
      // Renormalise only when needed so that written unit quaternions read back bit for bit.
      if (std::abs(len2 - 1.0) > 1e-14) r = r / std::sqrt(len2);
      return r;
    }
    const Vec3 a = direction(required(j, ptr, "axis"), child(ptr, "axis"));
    const double deg = number(required(j, ptr, "angleDeg"), child(ptr, "angleDeg"));
    return glm::angleAxis(glm::radians(deg), a);
  }

  // ---- nodes ---------------------------------------------------------------------------------

  Node node(const Json& j, const Ptr& ptr, std::size_t depth) {
    if (depth > limits::kMaxDepth) fail(ptr, "nodes nested deeper than 4096 levels");
    if (!j.is_object()) fail(ptr, "expected a node object, got " + typeOf(j));
    const std::string typeName = string(required(j, ptr, "type"), child(ptr, "type"));
    const TypeInfo* info = findType(typeName);
    if (!info) fail(child(ptr, "type"), "unknown node type " + quotedText(typeName) + " (expected one of " + typeList() + ")");
    if (info->category == Category::Primitive && j.contains("children"))
      fail(child(ptr, "children"), "a " + typeName + " is a primitive and cannot have children");
    checkKeys(j, ptr, {"type", "id", "transform"}, extraKeys(*info));

    Node n;
    if (j.contains("id")) {
      n.id = string(j["id"], child(ptr, "id"));
      if (n.id.empty()) fail(child(ptr, "id"), "id must not be empty");
    }
    if (j.contains("transform")) n.transform = transform(j["transform"], child(ptr, "transform"));
    if (info->category == Category::Instance) return instance(j, ptr, n, depth);

    if (++nodeCount_ > limits::kMaxNodes) fail(ptr, "more than 4000000 nodes");
    countIdBytes(n.id.size(), ptr);
    const bool tracked = !n.id.empty() && referenced_.count(n.id) && ids_[n.id].json == &j;
    if (tracked) inProgress_.insert(n.id);

    switch (info->category) {
      case Category::Primitive: n.kind = primitive(j, ptr, PrimitiveType(info->code)); break;
      case Category::Operator: n.kind = op(j, ptr, OperatorType(info->code)); break;
      case Category::Warp: n.kind = warp(j, ptr, WarpType(info->code)); break;
      case Category::Instance: break;
    }
    if (info->category != Category::Primitive) children(j, ptr, *info, n, depth);

    if (tracked) {
      inProgress_.erase(n.id);
      remember(n);
    }
    return n;
  }

  void children(const Json& j, const Ptr& ptr, const TypeInfo& info, Node& n, std::size_t depth) {
    const Ptr cp = child(ptr, "children");
    const Json& list = required(j, ptr, "children");
    if (!list.is_array()) fail(cp, "expected an array of nodes, got " + typeOf(list));
    const std::string name(info.name);
    if (info.category == Category::Warp && list.size() != 1)
      fail(cp, "a " + name + " warp needs exactly 1 child, got " + std::to_string(list.size()));
    if (info.category == Category::Operator) {
      if (list.empty()) fail(cp, "a " + name + " operator needs at least 1 child, got 0");
      if (info.code == int(OperatorType::Difference) || info.code == int(OperatorType::SmoothDifference))
        if (list.size() < 2) fail(cp, "a " + name + " needs at least 2 children, got " + std::to_string(list.size()));
    }
    n.children.reserve(list.size());
    for (std::size_t i = 0; i < list.size(); ++i) n.children.push_back(node(list[i], child(cp, i), depth + 1));
  }

  [[gnu::noinline]] Primitive primitive(const Json& j, const Ptr& ptr, PrimitiveType type) const {
    Primitive p;
    p.type = type;
    if (j.contains("colour")) p.colour = colour(j["colour"], child(ptr, "colour"));
    p.support = optionalPositive(j, ptr, "support", 1.0);
    if (const std::string problem = detail::belowMinimum("support", p.support, limits::kMinSupport); !problem.empty())
      fail(child(ptr, "support"), problem);
    switch (type) {
      case PrimitiveType::Point: p.a = optionalVec3(j, ptr, "centre", Vec3(0.0)); break;
      case PrimitiveType::Line:
        p.a = vec3(required(j, ptr, "start"), child(ptr, "start"));
        p.b = vec3(required(j, ptr, "end"), child(ptr, "end"));
        break;
      case PrimitiveType::Cylinder:
        p.a = optionalVec3(j, ptr, "base", Vec3(0.0));
        p.b = optionalDirection(j, ptr, "axis", 1);
        p.radius = positive(required(j, ptr, "radius"), child(ptr, "radius"), "radius");
        p.height = positive(required(j, ptr, "height"), child(ptr, "height"), "height");
        break;
      case PrimitiveType::Disc:
      case PrimitiveType::Ring:
        p.a = optionalVec3(j, ptr, "centre", Vec3(0.0));
        p.b = optionalDirection(j, ptr, "normal", 1);
        p.radius = positive(required(j, ptr, "radius"), child(ptr, "radius"), "radius");
        break;
      case PrimitiveType::Cube: {
        p.a = optionalVec3(j, ptr, "centre", Vec3(0.0));
        const Ptr hp = child(ptr, "halfExtents");
        const Json& h = required(j, ptr, "halfExtents");
        p.b = h.is_number() ? Vec3(number(h, hp)) : vec3(h, hp);
        for (int i = 0; i < 3; ++i)
          if (p.b[i] < 0.0)
            fail(h.is_number() ? hp : child(hp, std::size_t(i)),
                 "half extents must be >= 0, got " + detail::number(p.b[i]));
        break;
      }
      case PrimitiveType::Triangle: {
        const Ptr cp = child(ptr, "corners");
        const Json& c = required(j, ptr, "corners");
        if (!c.is_array() || c.size() != 3)
          fail(cp, "expected an array of 3 corners, got " +
                       (c.is_array() ? std::to_string(c.size()) + " elements" : typeOf(c)));
        p.a = vec3(c[0], child(cp, std::size_t(0)));
        p.b = vec3(c[1], child(cp, std::size_t(1)));
        p.c = vec3(c[2], child(cp, std::size_t(2)));
        if (!(glm::length(glm::cross(p.b - p.a, p.c - p.a)) > 1e-12))
          fail(cp, "triangle corners are collinear (zero area)");
        break;
      }
      case PrimitiveType::QuadricPoint:
        p.a = optionalVec3(j, ptr, "centre", Vec3(0.0));
        p.scale = optionalPositive(j, ptr, "scale", 1.0);
        break;
    }
    return p;
  }

  [[gnu::noinline]] Operator op(const Json& j, const Ptr& ptr, OperatorType type) const {
    Operator o;
    o.type = type;
    if (type == OperatorType::Ricci) {
      o.power = optionalPositive(j, ptr, "power", 2.0);
      if (const std::string problem = detail::belowMinimum("power", o.power, limits::kMinRicciPower, detail::kRicciOverflow);
          !problem.empty())
        fail(child(ptr, "power"), problem);
    }
    return o;
  }

  [[gnu::noinline]] Warp warp(const Json& j, const Ptr& ptr, WarpType type) const {
    Warp w;
    w.type = type;
    auto distinct = [&](const char* key) {
      if (w.axis == w.otherAxis)
        fail(child(ptr, key), "must differ from \"axis\" (both are " + std::string(1, "xyz"[w.axis]) + ")");
    };
    switch (type) {
      case WarpType::Twist:
        w.axis = optionalAxis(j, ptr, "axis", 2);
        w.factor = number(required(j, ptr, "factor"), child(ptr, "factor"));
        break;
      case WarpType::Taper:
        w.axis = optionalAxis(j, ptr, "axis", 2);
        w.otherAxis = optionalAxis(j, ptr, "taperAxis", 0);
        distinct("taperAxis");
        w.factor = number(required(j, ptr, "factor"), child(ptr, "factor"));
        break;
      case WarpType::Bend: {
        w.axis = optionalAxis(j, ptr, "axis", 1);
        w.otherAxis = optionalAxis(j, ptr, "towards", 2);
        distinct("towards");
        w.factor = number(required(j, ptr, "rate"), child(ptr, "rate"));
        if (w.factor == 0.0) fail(child(ptr, "rate"), "bend rate must be non-zero");
        if (j.contains("centre")) w.centre = number(j["centre"], child(ptr, "centre"));
        if (j.contains("lo")) w.lo = number(j["lo"], child(ptr, "lo"));
        if (j.contains("hi")) w.hi = number(j["hi"], child(ptr, "hi"));
        if (!(w.lo < w.hi)) fail(child(ptr, "hi"), "bend region needs lo < hi");
        break;
      }
      case WarpType::Shear:
        w.axis = optionalAxis(j, ptr, "axis", 0);
        w.otherAxis = optionalAxis(j, ptr, "by", 1);
        distinct("by");
        w.factor = number(required(j, ptr, "factor"), child(ptr, "factor"));
        break;
    }
    return w;
  }

  // ---- instancing ------------------------------------------------------------------------------

  struct IdEntry {
    const Json* json = nullptr;
    std::string pointer;
    std::string duplicatePointer;  // second definition, if any
  };

  // Finds every node id and every instance reference before parsing, so a node can be cached
  // when (and only when) an instance needs it.
  void indexIds(const Json& doc) {
    const Ptr top;
    if (doc.contains("root")) indexNode(doc["root"], child(top, "root"), 1);
    if (doc.contains("definitions") && doc["definitions"].is_array()) {
      const Json& defs = doc["definitions"];
      const Ptr dp = child(top, "definitions");
      for (std::size_t i = 0; i < defs.size(); ++i) indexNode(defs[i], child(dp, i), 1);
    }
  }

  void indexNode(const Json& j, const Ptr& ptr, std::size_t depth) {
    if (!j.is_object() || depth > limits::kMaxDepth) return;  // reported by node()
    const auto id = j.find("id");
    if (id != j.end() && id->is_string()) {
      IdEntry& e = ids_[id->get<std::string>()];
      if (!e.json) {
        e.json = &j;
        e.pointer = shortened(ptr.str());  // bounded: a deep tree of ids stays linear
      } else if (e.duplicatePointer.empty()) {
        e.duplicatePointer = shortened(ptr.str());
      }
    }
    const auto of = j.find("of");
    if (of != j.end() && of->is_string()) referenced_.insert(of->get<std::string>());
    const auto kids = j.find("children");
    const Ptr kidsPtr = child(ptr, "children");
    if (kids != j.end() && kids->is_array())
      for (std::size_t i = 0; i < kids->size(); ++i)
        indexNode((*kids)[i], child(kidsPtr, i), depth + 1);
  }

  // Keeps a node that instances copy, with its size so copies are checked in O(1).
  void remember(const Node& n) {
    resolved_[n.id] = n;
    resolvedSize_[n.id] = detail::measure(n);
  }

  void readDefinitions(const Json& doc) {
    if (!doc.contains("definitions")) return;
    const Ptr top;
    const Ptr dp = child(top, "definitions");
    const Json& defs = doc["definitions"];
    if (!defs.is_array()) fail(dp, "expected an array of nodes, got " + typeOf(defs));
    // Definitions are not part of the model: each is checked against the model's limits as a
    // model of its own, and only the root's expansion counts towards the model's. What the
    // reader keeps of them (each expanded once) is bounded too: twice the model's limits, which a
    // chain of definitions each doubling the last (together under twice the largest) meets.
    const std::size_t counted = nodeCount_, countedIdBytes = idBytes_;
    std::size_t definitionNodes = 0, definitionIdBytes = 0;
    for (std::size_t i = 0; i < defs.size(); ++i) {
      const Json& d = defs[i];
      if (d.is_object() && !d.contains("id")) fail(child(dp, i), "a definition needs an \"id\" to be instanced");
      nodeCount_ = 0, idBytes_ = 0;
      const Node n = node(d, child(dp, i), 1);
      definitionNodes += nodeCount_, definitionIdBytes += idBytes_;
      if (definitionNodes > 2 * limits::kMaxNodes)
        fail(child(dp, i), "the definitions hold more than " + std::to_string(2 * limits::kMaxNodes) +
                               " nodes after instancing");
      if (definitionIdBytes > 2 * limits::kMaxIdBytes)
        fail(child(dp, i), "the ids of the definitions' nodes after instancing take more than 128 MiB");
      if (!resolved_.count(n.id) && ids_[n.id].json == &d) remember(n);
    }
    nodeCount_ = counted, idBytes_ = countedIdBytes;
  }

  [[gnu::noinline]] Node instance(const Json& j, const Ptr& ptr, const Node& header, std::size_t depth) {
    const Ptr op = child(ptr, "of");
    const std::string target = string(required(j, ptr, "of"), op);
    const auto it = ids_.find(target);
    if (it == ids_.end()) fail(op, "instance refers to unknown id " + quotedText(target));
    if (!it->second.duplicatePointer.empty())
      fail(op, "instance refers to id " + quotedText(target) + " which is defined twice (" +
                   shortened(it->second.pointer) + " and " + shortened(it->second.duplicatePointer) + ")");
    if (inProgress_.count(target)) fail(op, "instance of " + quotedText(target) + " contains itself");
    auto cached = resolved_.find(target);
    if (cached == resolved_.end()) {
      // Parse the target where it stands; errors inside it name its own pointer.
      const std::size_t counted = nodeCount_, countedIdBytes = idBytes_;
      const Ptr at{nullptr, &it->second.pointer, {}, 0, false};
      // In progress while it is read: a target that is itself an instance is not tracked by
      // node(), and a cycle made of instances only would otherwise recurse without end.
      inProgress_.insert(target);
      const Node n = node(*it->second.json, at, depth);
      inProgress_.erase(target);
      nodeCount_ = counted, idBytes_ = countedIdBytes;
      cached = resolved_.find(target);
      if (cached == resolved_.end()) {  // an instance of an instance: node() remembers no instance
        remember(n);
        cached = resolved_.find(target);
      }
    }
    const detail::SubtreeSize size = resolvedSize_.at(target);
    if (depth + size.height - 1 > limits::kMaxDepth) fail(ptr, "nodes nested deeper than 4096 levels after instancing");
    nodeCount_ += size.nodes;
    if (nodeCount_ > limits::kMaxNodes) fail(ptr, "more than 4000000 nodes after instancing");
    countIdBytes(size.idBytes, ptr);
    return detail::instantiate(cached->second, header.transform, header.id);
  }

  // ---- camera and grid -------------------------------------------------------------------------

  Camera camera(const Json& j, const Ptr& ptr) const {
    if (!j.is_object()) fail(ptr, "expected a camera object, got " + typeOf(j));
    checkKeys(j, ptr, {"eye", "target", "up", "azimuthDeg", "elevationDeg", "distance", "fovYDeg"});
    Camera c;
    if (j.contains("eye")) c.eye = vec3(j["eye"], child(ptr, "eye"));
    if (j.contains("target")) c.target = vec3(j["target"], child(ptr, "target"));
    if (j.contains("up")) {
      c.up = vec3(j["up"], child(ptr, "up"));
      if (!(glm::length(*c.up) > 1e-9)) fail(child(ptr, "up"), "up vector cannot be normalised (zero length)");
    }
    if (j.contains("azimuthDeg")) c.azimuthDeg = number(j["azimuthDeg"], child(ptr, "azimuthDeg"));
    if (j.contains("elevationDeg")) {
      c.elevationDeg = number(j["elevationDeg"], child(ptr, "elevationDeg"));
      if (std::abs(*c.elevationDeg) > 90.0)
        fail(child(ptr, "elevationDeg"), "elevation must be within [-90, 90] degrees");
    }
    if (j.contains("distance")) c.distance = positive(j["distance"], child(ptr, "distance"), "distance");
    if (j.contains("fovYDeg")) {
      c.fovYDeg = number(j["fovYDeg"], child(ptr, "fovYDeg"));
      if (!(c.fovYDeg > 0.0 && c.fovYDeg < 180.0))
        fail(child(ptr, "fovYDeg"), "field of view must be within (0, 180) degrees, got " + detail::number(c.fovYDeg));
    }
    if (c.eye && c.target && glm::length(*c.eye - *c.target) < 1e-9)
      fail(child(ptr, "target"), "eye and target coincide");
    return c;
  }

  GridSettings grid(const Json& j, const Ptr& ptr) const {
    if (!j.is_object()) fail(ptr, "expected a grid object, got " + typeOf(j));
    checkKeys(j, ptr, {"cellSize", "resolution", "bounds"});
    GridSettings g;
    if (j.contains("cellSize") && j.contains("resolution"))
      fail(ptr, "give \"cellSize\" or \"resolution\", not both");
    if (j.contains("cellSize")) g.cellSize = positive(j["cellSize"], child(ptr, "cellSize"), "cellSize");
    if (j.contains("resolution")) {
      const Json& r = j["resolution"];
      const Ptr rp = child(ptr, "resolution");
      // 24.0 and 1e3 are JSON floats: name the rule, not a "fraction" they do not have.
      if (r.is_number_float())
        fail(rp, "expected an integer written without a decimal point or exponent, got " + detail::number(r.get<double>()));
      if (!r.is_number_integer()) fail(rp, "expected an integer, got " + typeOf(r));
      // Unsigned integers above 2^63 read as negative int64s: name them as written.
      const std::string written = r.is_number_unsigned() ? std::to_string(r.get<std::uint64_t>()) : std::to_string(r.get<std::int64_t>());
      const auto v = r.is_number_unsigned() && r.get<std::uint64_t>() > 16384u ? std::int64_t(16385) : r.get<std::int64_t>();
      if (v < 1 || v > 16384) fail(rp, "resolution must be within [1, 16384], got " + written);
      g.resolution = int(v);
    }
    if (j.contains("bounds")) {
      const Ptr bp = child(ptr, "bounds");
      const Json& b = j["bounds"];
      if (!b.is_object()) fail(bp, "expected {\"lo\": [x, y, z], \"hi\": [x, y, z]}, got " + typeOf(b));
      checkKeys(b, bp, {"lo", "hi"});
      g.boundsLo = vec3(required(b, bp, "lo"), child(bp, "lo"));
      g.boundsHi = vec3(required(b, bp, "hi"), child(bp, "hi"));
      for (int i = 0; i < 3; ++i)
        if (!((*g.boundsLo)[i] < (*g.boundsHi)[i]))
          fail(child(child(bp, "hi"), std::size_t(i)), "bounds need lo < hi on every axis");
    }
    return g;
  }

  std::string source_;
  std::map<std::string, IdEntry> ids_;
  std::set<std::string> referenced_;
  std::map<std::string, Node> resolved_;
  std::map<std::string, detail::SubtreeSize> resolvedSize_;
  std::set<std::string> inProgress_;
  std::size_t nodeCount_ = 0;
  std::size_t idBytes_ = 0;  // limits::kMaxIdBytes

  void countIdBytes(std::size_t bytes, const Ptr& ptr) {
    idBytes_ += bytes;
    if (idBytes_ > limits::kMaxIdBytes) fail(ptr, "the ids of the nodes after instancing take more than 64 MiB");
  }
};

// Our readers recurse once per nesting level; refuse absurd nesting before nlohmann even
// builds the document. A node level costs two JSON levels (the node and its children array).
void checkNesting(std::string_view text, const std::string& source) {
  constexpr std::size_t kMaxJsonNesting = 2 * limits::kMaxDepth + 8;
  std::size_t depth = 0, line = 1;
  bool inString = false, escaped = false;
  for (char c : text) {
    if (c == '\n') ++line;
    if (inString) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') inString = false;
      continue;
    }
    if (c == '"') inString = true;
    else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonNesting)
        throw SceneError(source, "line " + std::to_string(line),
                         "JSON nested deeper than " + std::to_string(kMaxJsonNesting) + " levels (nodes nest at most " +
                             std::to_string(limits::kMaxDepth) + " deep, two JSON levels each)");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

// Refuses a key repeated within one object: nlohmann keeps the last value and drops the others
// silently, and a reader that is strict must not guess which one was meant. A SAX pass of its
// own rather than a parser callback: nlohmann's callback parser rescans the enclosing array at
// every object's end, which made a node with n children cost O(n^2) to read.
// Tracks the containers being read (their keys, and each array's element count) for the pointer.
class DuplicateKeyCheck : public nlohmann::json_sax<Json> {
 public:
  explicit DuplicateKeyCheck(std::string source) : source_(std::move(source)) {}

  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override { return open(true); }
  bool start_array(std::size_t) override { return open(false); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }

  bool key(string_t& key) override {
    Frame& top = frames_.back();
    top.key = key;
    if (!top.keys.insert(key).second)
      throw SceneError(source_, pointer(), "key \"" + key + "\" appears twice in one object");
    return true;
  }

  // Malformed JSON stops the check quietly; the parse that follows reports it in nlohmann's words.
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
    return false;
  }

 private:
  struct Frame {
    bool object = true;
    std::set<std::string> keys;
    std::string key;       // an object's current key
    long long index = -1;  // an array's current element
  };

  bool value() {
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
    return true;
  }
  bool open(bool object) {
    value();
    frames_.push_back({object, {}, {}, -1});
    return true;
  }
  bool close() {
    if (!frames_.empty()) frames_.pop_back();
    return true;
  }

  // The JSON pointer of the current key (RFC 6901: '~' as ~0, '/' as ~1).
  std::string pointer() const {
    std::string p;
    for (const Frame& f : frames_) {
      p += '/';
      if (!f.object) {
        p += std::to_string(f.index);
        continue;
      }
      p += pointerToken(f.key);
    }
    return p;
  }
  std::string source_;
  std::vector<Frame> frames_;
};

}  // namespace

// Run before the document is built, so that a repeated key earlier in the text than a syntax
// error is the one reported, as when the check was a callback of the parse itself.
void refuseDuplicateKeys(std::string_view text, const std::string& source) {
  DuplicateKeyCheck check(source);
  Json::sax_parse(text.begin(), text.end(), &check);
}

SceneError malformedJson(const std::exception& parseFailure, std::string_view text, const std::string& sourceName) {
  if (const auto* e = dynamic_cast<const Json::parse_error*>(&parseFailure)) {
    // nlohmann says "...parse error at line L, column C: <problem>"; keep L, C and the problem.
    const std::string what = e->what();
    std::string location = "byte " + std::to_string(e->byte), problem = what;
    const auto at = what.find("at line ");
    if (at != std::string::npos) {
      const auto colon = what.find(": ", at);
      if (colon != std::string::npos) {
        location = what.substr(at + 3, colon - at - 3);
        problem = what.substr(colon + 2);
      }
    }
    return SceneError(sourceName, location, "malformed JSON: " + problem);
  }
  // Number overflow ("number overflow parsing '1e999'") carries no position: find the token.
  std::string what = parseFailure.what();
  const auto bracket = what.find("] ");
  if (bracket != std::string::npos) what = what.substr(bracket + 2);
  std::string location = "line 1";
  const auto q0 = what.find('\''), q1 = what.rfind('\'');
  if (q0 != std::string::npos && q1 > q0) {
    const auto at = text.find(what.substr(q0 + 1, q1 - q0 - 1));
    if (at != std::string_view::npos) {
      const auto lineStart = text.rfind('\n', at);
      const std::size_t line = 1 + std::size_t(std::count(text.begin(), text.begin() + long(at), '\n'));
      const std::size_t column = at - (lineStart == std::string_view::npos ? 0 : lineStart + 1) + 1;
      location = "line " + std::to_string(line) + ", column " + std::to_string(column);
    }
  }
  return SceneError(sourceName, location, "malformed JSON: " + what);
}

Scene parseSceneJson(std::string_view text, const std::string& sourceName) {
  checkNesting(text, sourceName);
  refuseDuplicateKeys(text, sourceName);
  Json doc;
  try {
    doc = Json::parse(text.begin(), text.end());
  } catch (const Json::exception& e) {
    throw malformedJson(e, text, sourceName);
  }
  return Reader(sourceName).read(doc);
}

Scene readSceneJson(const std::string& path) {
  return parseSceneJson(detail::readWholeFile(path), path);
}

}  // namespace blobvk::blobtree
