// Reader of the thesis' legacy INI-style BlobTree files (ReadSceneModel.cpp's format, thesis
// §8). Unknown keys are ignored (the editor wrote many we do not need: materials, layer counts),
// but every key we use is checked, and every failure names its line.
#include "blobvk/blobtree/scene_blob.h"
#include "blobvk/blobtree/decimal.h"
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_instance.h"
#include "blobvk/blobtree/scene_limits.h"
#include "blobvk/blobtree/scene_text.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <vector>

namespace blobvk::blobtree {
namespace {

using detail::quotedText;

struct Entry {
  std::string value;
  std::size_t line = 0;
};

struct Section {
  std::string name;  // lower case: "blobnode", "global", ...
  std::string id;    // the BLOBNODE id
  std::size_t line = 0;
  std::map<std::string, Entry> keys;  // lower-case key -> value
};

std::string trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\f\v");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r\f\v");
  return std::string(s.substr(first, last - first + 1));
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Upper case without spaces, underscores or hyphens: "Ricci Blend" -> "RICCIBLEND".
std::string normalisedName(std::string_view s) {
  std::string out;
  for (char c : s)
    if (c != ' ' && c != '_' && c != '-' && c != '\t') out += char(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

class BlobReader {
 public:
  BlobReader(std::string_view text, const std::string& source) : source_(source) {
    split(text);
    countReferences();
  }

  Scene read() {
    const Section* global = nullptr;
    for (const Section& s : sections_)
      if (s.name == "global") global = &s;
    if (!global) fail(lastLine_, "no [Global] section (it names the root with RootIDs=(id))");
    if (const Entry* layers = find(*global, "numlayers")) {
      const double n = number(*layers, layers->value, "NumLayers");
      if (n != 1.0) fail(layers->line, "only files with NumLayers=1 are supported, got " + layers->value);
    }
    const Entry* rootIds = find(*global, "rootids");
    if (!rootIds) fail(global->line, "[Global] has no RootIDs=(id)");
    const auto roots = list(*rootIds);
    if (roots.empty()) fail(rootIds->line, "RootIDs is empty");

    Scene scene;
    std::vector<Node> built;
    for (const std::string& id : roots) built.push_back(node(id, rootIds->line, 1));
    if (built.size() == 1) {
      scene.root = std::move(built.front());
    } else {  // several roots: their union, as the editor draws them side by side
      scene.root.kind = Operator{OperatorType::Union, 2.0};
      scene.root.children = std::move(built);
    }
    return scene;
  }

 private:
  [[noreturn]] void fail(std::size_t line, const std::string& problem) const {
    throw SceneError(source_, "line " + std::to_string(line), problem);
  }

  // ---- lexing ----------------------------------------------------------------------------------

  void split(std::string_view text) {
    std::size_t lineNo = 0, pos = 0;
    if (text.substr(0, 3) == "\xEF\xBB\xBF") pos = 3;  // a UTF-8 byte order mark, as editors on Windows save
    Section* current = nullptr;
    while (pos < text.size()) {  // a final newline does not start another line
      std::size_t end = text.find('\n', pos);
      if (end == std::string_view::npos) end = text.size();
      std::string raw(text.substr(pos, end - pos));
      pos = end + 1;
      ++lineNo;
      raw.erase(std::remove(raw.begin(), raw.end(), '\0'), raw.end());  // old .scene files
      const std::string line = trim(raw);
      if (line.empty() || line[0] == '#' || line[0] == ';' || line.rfind("//", 0) == 0) continue;
      if (line.front() == '[') {
        if (line.back() != ']') fail(lineNo, "section header " + quotedText(line) + " is missing its ']'");
        current = &header(trim(std::string_view(line).substr(1, line.size() - 2)), lineNo);
        continue;
      }
      const auto eq = line.find('=');
      if (eq == std::string::npos) fail(lineNo, "expected 'key=value' or a [section] header, got " + quotedText(line));
      if (!current) fail(lineNo, "key " + quotedText(trim(line.substr(0, eq))) + " appears before any [section]");
      const std::string key = lower(trim(std::string_view(line).substr(0, eq)));
      if (key.empty()) fail(lineNo, "empty key before '='");
      auto [it, inserted] = current->keys.emplace(key, Entry{trim(std::string_view(line).substr(eq + 1)), lineNo});
      if (!inserted)
        fail(lineNo, "key " + quotedText(key) + " given twice in one section (first at line " + std::to_string(it->second.line) + ")");
    }
    lastLine_ = std::max<std::size_t>(lineNo, 1);
  }

  Section& header(const std::string& title, std::size_t lineNo) {
    Section s;
    s.line = lineNo;
    const auto space = title.find_first_of(" \t");
    s.name = lower(title.substr(0, space));
    if (s.name == "blobnode") {
      s.id = space == std::string::npos ? "" : trim(std::string_view(title).substr(space));
      if (s.id.empty()) fail(lineNo, "[BLOBNODE] needs an id, as in [BLOBNODE 3]");
      const auto known = nodeIndex_.find(s.id);
      if (known != nodeIndex_.end())
        fail(lineNo, "duplicate node id " + quotedText(s.id) + " (first at line " +
                         std::to_string(sections_[known->second].line) + ")");
      nodeIndex_[s.id] = sections_.size();
    } else if (s.name == "global") {
      // A second [Global] (two files joined) would silently replace the first one's roots.
      for (const Section& other : sections_)
        if (other.name == "global")
          fail(lineNo, "[Global] given twice (first at line " + std::to_string(other.line) + ")");
    }
    sections_.push_back(std::move(s));
    return sections_.back();
  }

  // ---- values ----------------------------------------------------------------------------------

  static const Entry* find(const Section& s, const std::string& key) {
    const auto it = s.keys.find(key);
    return it == s.keys.end() ? nullptr : &it->second;
  }

  const Entry& required(const Section& s, const std::string& key, std::string_view shown) const {
    const Entry* e = find(s, key);
    if (!e) fail(s.line, "node " + quotedText(s.id) + " is missing " + std::string(shown) + "=");
    return *e;
  }

  // "(a, b, c)" or "a, b, c" -> trimmed items; "()" -> none.
  std::vector<std::string> list(const Entry& e) const {
    std::string v = e.value;
    if (!v.empty() && v.front() == '(') {
      if (v.back() != ')') fail(e.line, "unbalanced parentheses in " + quotedText(v));
      v = v.substr(1, v.size() - 2);
    }
    std::vector<std::string> items;
    if (trim(v).empty()) return items;
    std::size_t pos = 0;
    while (true) {
      const auto comma = v.find(',', pos);
      items.push_back(trim(std::string_view(v).substr(pos, comma == std::string::npos ? std::string::npos : comma - pos)));
      if (items.back().empty()) fail(e.line, "empty item in list " + quotedText(e.value));
      if (comma == std::string::npos) break;
      pos = comma + 1;
    }
    return items;
  }

  double number(const Entry& e, const std::string& text, std::string_view what) const {
    // A number past double's range is still a number: one too small reads as its nearest double
    // (0 or a denormal, as the JSON reader takes it), one too large is out of range below.
    const std::optional<Decimal> d = readDecimal(text);
    if (!d) fail(e.line, std::string(what) + ": " + quotedText(text) + " is not a number");
    const double v = d->value;
    if (d->beyondDouble && !std::isfinite(v))
      fail(e.line, std::string(what) + ": value " + text + " is out of range (|x| must be <= 1e6)");
    if (!std::isfinite(v)) fail(e.line, std::string(what) + ": value is not finite");
    if (std::abs(v) > limits::kMaxAbsValue)
      fail(e.line, std::string(what) + ": value " + detail::number(v) + " is out of range (|x| must be <= 1e6)");
    return v;
  }

  std::vector<double> numbers(const Entry& e, std::string_view what, std::size_t minCount, std::size_t maxCount) const {
    const auto items = list(e);
    if (items.size() < minCount || items.size() > maxCount)
      fail(e.line, std::string(what) + " needs " + std::to_string(minCount) +
                       (maxCount != minCount ? " to " + std::to_string(maxCount) : "") + " numbers, got " +
                       std::to_string(items.size()));
    std::vector<double> out;
    for (const auto& item : items) out.push_back(number(e, item, what));
    return out;
  }

  Vec3 vec3(const Entry& e, std::string_view what) const {
    const auto v = numbers(e, what, 3, 3);
    return Vec3(v[0], v[1], v[2]);
  }

  double positive(const Entry& e, std::string_view what) const {
    const double v = numbers(e, what, 1, 1)[0];
    if (!(v > 0.0)) fail(e.line, std::string(what) + " must be > 0, got " + detail::number(v));
    return v;
  }

  Vec3 direction(const Entry& e, std::string_view what) const {
    const Vec3 v = vec3(e, what);
    const double len = glm::length(v);
    if (!(len > 1e-9)) fail(e.line, std::string(what) + " cannot be normalised (zero length)");
    return v / len;
  }

  int axis(const Entry& e, std::string_view what) const {
    const std::string v = lower(e.value);
    if (v == "0" || v == "x") return 0;
    if (v == "1" || v == "y") return 1;
    if (v == "2" || v == "z") return 2;
    fail(e.line, std::string(what) + ": " + quotedText(e.value) + " is not an axis (0, 1, 2 or x, y, z)");
  }

  // ---- tree --------------------------------------------------------------------------------------

  const Section& section(const std::string& id, std::size_t refLine) const {
    const auto it = nodeIndex_.find(id);
    if (it == nodeIndex_.end()) fail(refLine, "reference to unknown node id " + quotedText(id));
    return sections_[it->second];
  }

  // How often each id is referenced; only nodes used more than once are cached for copying.
  void countReferences() {
    for (const Section& s : sections_) {
      if (s.name != "blobnode") continue;
      try {
        std::size_t line = 0;
        if (isOperator(s)) {
          if (find(s, "operatortype"))
            for (const std::string& id : childIds(s, line)) ++references_[id];
        } else if (const Entry* original = find(s, "originalnodeindex")) {
          ++references_[original->value];
        }
      } catch (const SceneError&) {
        // reported with its line when the node is built
      }
    }
  }

  Node node(const std::string& id, std::size_t refLine, std::size_t depth) {
    if (depth > limits::kMaxDepth) fail(refLine, "nodes nested deeper than 4096 levels");
    if (onPath_.count(id)) fail(refLine, "cycle: node " + quotedText(id) + " contains itself");
    if (const auto cached = built_.find(id); cached != built_.end()) return copy(cached->second, refLine, depth);
    const Section& s = section(id, refLine);
    onPath_.insert(id);
    Node n = fresh(s, depth);
    onPath_.erase(id);
    if (references_[id] > 1) built_[id] = n;
    return n;
  }

  // A node used twice (a DAG in the file) becomes two copies in the tree; keep the limits.
  Node copy(const Node& n, std::size_t refLine, std::size_t depth) {
    const detail::SubtreeSize size = detail::measure(n);
    if (depth + size.height - 1 > limits::kMaxDepth) fail(refLine, "nodes nested deeper than 4096 levels");
    countNodes(size.nodes, refLine, size.idBytes);
    return n;
  }

  void countNodes(std::size_t n, std::size_t line, std::size_t idBytes) {
    nodeCount_ += n;
    if (nodeCount_ > limits::kMaxNodes) fail(line, "more than 4000000 nodes");
    idBytes_ += idBytes;
    if (idBytes_ > limits::kMaxIdBytes) fail(line, "the ids of the nodes after instancing take more than 64 MiB");
  }

  bool isOperator(const Section& s) const {
    if (const Entry* e = find(s, "isoperator")) {
      if (e->value == "1") return true;
      if (e->value == "0") return false;
      fail(e->line, "IsOperator must be 0 or 1, got " + quotedText(e->value));
    }
    return find(s, "operatortype") != nullptr;
  }

  Transform transform(const Section& s) const {
    Transform t;
    if (const Entry* e = find(s, "affinescale")) {
      t.scale = vec3(*e, "AffineScale");
      for (int i = 0; i < 3; ++i)
        if (!(t.scale[i] > 0.0)) fail(e->line, "AffineScale must be > 0 on every axis, got " + detail::number(t.scale[i]));
    }
    if (const Entry* e = find(s, "affinerotate")) {
      const auto q = numbers(*e, "AffineRotate", 4, 4);  // x, y, z, w
      Quat r(q[3], q[0], q[1], q[2]);
      const double len2 = glm::dot(r, r);
      if (!(len2 > 1e-18)) fail(e->line, "AffineRotate quaternion cannot be normalised (zero length)");
      t.rotate = r / std::sqrt(len2);
    }
    if (const Entry* e = find(s, "affinetranslate")) t.translate = vec3(*e, "AffineTranslate");
    return t;
  }

  Node fresh(const Section& s, std::size_t depth) {
    countNodes(1, s.line, s.id.size());
    Node n;
    n.id = s.id;
    n.transform = transform(s);
    if (isOperator(s)) {
      operatorNode(s, n, depth);
      return n;
    }
    const Entry& typeEntry = find(s, "primitivetype") ? *find(s, "primitivetype") : required(s, "skeletontype", "PrimitiveType");
    const std::string type = normalisedName(typeEntry.value);
    // The older key and the newer one name the same thing: two different answers are a mistake.
    if (const Entry* older = find(s, "skeletontype"); older && older != &typeEntry && normalisedName(older->value) != type)
      fail(older->line, "SkeletonType=" + older->value + " contradicts PrimitiveType=" + typeEntry.value + " (line " +
                            std::to_string(typeEntry.line) + "): give one");
    if (type == "INSTANCE") {
      const Entry& original = required(s, "originalnodeindex", "OriginalNodeIndex");
      --nodeCount_;  // the instance itself is replaced by its copy (counted by node())
      return detail::instantiate(node(original.value, original.line, depth), n.transform, n.id);
    }
    n.kind = primitive(s, type, typeEntry);
    return n;
  }

  Primitive primitive(const Section& s, const std::string& type, const Entry& typeEntry) const {
    Primitive p;
    if (const Entry* e = find(s, "mtrldiffused")) {
      const auto c = numbers(*e, "MtrlDiffused", 3, 4);
      for (int i = 0; i < 3; ++i) {
        if (c[i] < 0.0 || c[i] > 1.0) fail(e->line, "MtrlDiffused components must be within [0, 1], got " + detail::number(c[i]));
        p.colour[i] = c[i];
      }
    }
    auto position = [&] { return find(s, "position") ? vec3(*find(s, "position"), "position") : Vec3(0.0); };
    auto dir = [&] { return find(s, "direction") ? direction(*find(s, "direction"), "direction") : Vec3(0.0, 1.0, 0.0); };
    auto radius = [&] { return positive(required(s, "radius", "radius"), "radius"); };
    if (type == "POINT") {
      p.type = PrimitiveType::Point;
      p.a = position();
    } else if (type == "LINE") {
      p.type = PrimitiveType::Line;
      p.a = vec3(required(s, "start", "start"), "start");
      p.b = vec3(required(s, "end", "end"), "end");
    } else if (type == "CYLINDER") {
      p.type = PrimitiveType::Cylinder;
      p.a = position();
      p.b = dir();
      p.radius = radius();
      p.height = positive(required(s, "height", "height"), "height");
    } else if (type == "DISC" || type == "RING") {
      p.type = type == "DISC" ? PrimitiveType::Disc : PrimitiveType::Ring;
      p.a = position();
      p.b = dir();
      p.radius = radius();
    } else if (type == "CUBE") {
      p.type = PrimitiveType::Cube;
      p.a = position();
      p.b = Vec3(positive(required(s, "side", "side"), "side"));  // the thesis' side is the half side
    } else if (type == "TRIANGLE") {
      p.type = PrimitiveType::Triangle;
      p.a = vec3(required(s, "corner0", "corner0"), "corner0");
      p.b = vec3(required(s, "corner1", "corner1"), "corner1");
      p.c = vec3(required(s, "corner2", "corner2"), "corner2");
      if (!(glm::length(glm::cross(p.b - p.a, p.c - p.a)) > 1e-12))
        fail(s.line, "triangle " + quotedText(s.id) + " has collinear corners (zero area)");
    } else if (type == "QUADRICPOINT") {
      p.type = PrimitiveType::QuadricPoint;
      p.a = position();
      p.scale = positive(required(s, "scale", "scale"), "scale");
      const Entry& radius = required(s, "radius", "radius");
      p.support = positive(radius, "radius");
      if (const std::string problem = detail::belowMinimum("radius", p.support, limits::kMinSupport); !problem.empty())
        fail(radius.line, problem);
    } else if (type == "NULL") {
      fail(typeEntry.line, "a NULL primitive may only pad an operator's children");
    } else {
      fail(typeEntry.line, "unknown primitive type " + quotedText(typeEntry.value) +
                               " (expected POINT, LINE, CYLINDER, DISC, RING, CUBE, TRIANGLE, QUADRICPOINT, NULL or INSTANCE)");
    }
    return p;
  }

  std::vector<std::string> childIds(const Section& s, std::size_t& line) const {
    const Entry* useRange = find(s, "childrenidsuserange");
    if (useRange && useRange->value != "0" && useRange->value != "1")
      fail(useRange->line, "ChildrenIDsUseRange must be 0 or 1, got " + quotedText(useRange->value));
    std::vector<std::string> ids;
    if (useRange && useRange->value == "1") {
      const Entry& range = required(s, "childrenidsrange", "ChildrenIDsRange");
      line = range.line;
      const auto r = numbers(range, "ChildrenIDsRange", 2, 2);
      if (r[0] != std::floor(r[0]) || r[1] != std::floor(r[1]) || r[0] > r[1])
        fail(range.line, "ChildrenIDsRange needs integers first <= last, got " + quotedText(range.value));
      if (r[1] - r[0] >= double(limits::kMaxNodes)) fail(range.line, "ChildrenIDsRange is absurdly long");
      for (auto i = std::int64_t(r[0]); i <= std::int64_t(r[1]); ++i) ids.push_back(std::to_string(i));
    } else {
      const Entry& list_ = required(s, "childrenids", "ChildrenIDs");
      line = list_.line;
      ids = list(list_);
    }
    if (const Entry* count = find(s, "childrencount")) {
      if (count->value != std::to_string(ids.size()))
        fail(count->line, "ChildrenCount=" + count->value + " but " + std::to_string(ids.size()) + " children are listed");
    }
    return ids;
  }

  bool isNullPrimitive(const std::string& id) const {
    const auto it = nodeIndex_.find(id);
    if (it == nodeIndex_.end()) return false;
    const Section& s = sections_[it->second];
    if (isOperator(s)) return false;
    const Entry* t = find(s, "primitivetype");
    if (!t) t = find(s, "skeletontype");
    return t && normalisedName(t->value) == "NULL";
  }

  void operatorNode(const Section& s, Node& n, std::size_t depth) {
    const Entry& typeEntry = required(s, "operatortype", "OperatorType");
    const std::string type = normalisedName(typeEntry.value);
    auto get = [&](const char* key, const char* shown) -> const Entry& { return required(s, key, shown); };
    bool isWarp = false;
    if (type == "UNION" || type == "CACHE") {  // a cache is a pass-through of its child
      n.kind = Operator{OperatorType::Union, 2.0};
    } else if (type == "BLEND" || type == "FASTQUADRICPOINTSET") {  // a point set sums its points
      n.kind = Operator{OperatorType::Blend, 2.0};
    } else if (type == "RICCIBLEND" || type == "RICCI") {
      const Entry* power = find(s, "power");
      const double ricciPower = power ? positive(*power, "power") : 2.0;
      if (const std::string problem = detail::belowMinimum("power", ricciPower, limits::kMinRicciPower, detail::kRicciOverflow);
          !problem.empty())
        fail(power->line, problem);
      n.kind = Operator{OperatorType::Ricci, ricciPower};
    } else if (type == "INTERSECTION" || type == "INTERSECT") {
      n.kind = Operator{OperatorType::Intersection, 2.0};
    } else if (type == "DIFFERENCE" || type == "DIF") {
      n.kind = Operator{OperatorType::Difference, 2.0};
    } else if (type == "SMOOTHDIFFERENCE" || type == "SMOOTHDIF") {
      n.kind = Operator{OperatorType::SmoothDifference, 2.0};
    } else if (type == "TWIST") {
      isWarp = true;
      Warp w{WarpType::Twist, 2, 0};
      if (const Entry* a = find(s, "axis")) w.axis = axis(*a, "axis");
      w.factor = numbers(get("factor", "factor"), "factor", 1, 1)[0];
      n.kind = w;
    } else if (type == "TAPER") {
      isWarp = true;
      Warp w{WarpType::Taper, 2, 0};
      if (const Entry* a = find(s, "base axis")) w.axis = axis(*a, "base axis");
      if (const Entry* b = find(s, "taper axis")) w.otherAxis = axis(*b, "taper axis");
      if (w.axis == w.otherAxis) fail(s.line, "TAPER needs different base and taper axes");
      w.factor = numbers(get("factor", "factor"), "factor", 1, 1)[0];
      n.kind = w;
    } else if (type == "BEND") {
      isWarp = true;
      Warp w{WarpType::Bend, 1, 2};  // the thesis bends along y towards z
      const Entry& rate = get("rate", "rate");
      w.factor = numbers(rate, "rate", 1, 1)[0];
      if (w.factor == 0.0) fail(rate.line, "BEND rate must be non-zero");
      if (const Entry* c = find(s, "center")) w.centre = numbers(*c, "center", 1, 1)[0];
      if (const Entry* l = find(s, "left bound")) w.lo = numbers(*l, "left bound", 1, 1)[0];
      if (const Entry* r = find(s, "right bound")) w.hi = numbers(*r, "right bound", 1, 1)[0];
      if (!(w.lo < w.hi)) fail(s.line, "BEND needs left bound < right bound");
      n.kind = w;
    } else if (type == "SHEAR") {
      isWarp = true;
      Warp w{WarpType::Shear, 0, 1};
      if (const Entry* a = find(s, "base axis")) w.axis = axis(*a, "base axis");
      if (const Entry* b = find(s, "shear axis")) w.otherAxis = axis(*b, "shear axis");
      if (w.axis == w.otherAxis) fail(s.line, "SHEAR needs different base and shear axes");
      w.factor = numbers(get("factor", "factor"), "factor", 1, 1)[0];
      n.kind = w;
    } else {
      fail(typeEntry.line, "unknown operator type " + quotedText(typeEntry.value) +
                               " (expected UNION, BLEND, RICCI BLEND, INTERSECTION, DIFFERENCE, SMOOTH DIFFERENCE, "
                               "TWIST, TAPER, BEND, SHEAR, CACHE or FASTQUADRICPOINTSET)");
    }

    std::size_t line = s.line;
    const auto ids = childIds(s, line);
    for (const std::string& id : ids) {
      if (isNullPrimitive(id)) continue;  // padding from the editor's binary-tree conversion
      n.children.push_back(node(id, line, depth + 1));
    }
    const std::size_t count = n.children.size();
    if (isWarp && count != 1) fail(line, "a " + typeEntry.value + " warp needs exactly 1 child, got " + std::to_string(count));
    if (count == 0) fail(line, "operator " + quotedText(s.id) + " has no children");
    const auto op = std::get_if<Operator>(&n.kind);
    if (op && (op->type == OperatorType::Difference || op->type == OperatorType::SmoothDifference) && count < 2)
      fail(line, "a " + typeEntry.value + " needs at least 2 children, got " + std::to_string(count));
  }

  std::string source_;
  std::vector<Section> sections_;
  std::map<std::string, std::size_t> nodeIndex_;  // BLOBNODE id -> index in sections_
  std::map<std::string, std::size_t> references_;
  std::size_t lastLine_ = 0;
  std::set<std::string> onPath_;
  std::map<std::string, Node> built_;
  std::size_t nodeCount_ = 0;
  std::size_t idBytes_ = 0;  // limits::kMaxIdBytes
};

}  // namespace

Scene parseSceneBlob(std::string_view text, const std::string& sourceName) {
  return BlobReader(text, sourceName).read();
}

Scene readSceneBlob(const std::string& path) {
  return parseSceneBlob(detail::readWholeFile(path), path);
}

}  // namespace blobvk::blobtree
