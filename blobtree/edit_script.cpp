// The edit-script reader. Node contents ("set" and "add") go through the scene reader itself
// (parseSceneJson on a one-node scene), so they are checked exactly as scene files are; its
// error locations ("/root/...") are renamed to the script's ("/edits/3/set/...").
#include "blobvk/blobtree/edit_script.h"

#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/blobtree/scene_text.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <stdexcept>
#include <unordered_map>

namespace blobvk::blobtree {
namespace {

using Json = nlohmann::ordered_json;

std::string typeOf(const Json& j) {
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_boolean()) return "a boolean";
  if (j.is_null()) return "null";
  if (j.is_array()) return "an array";
  return "an object";
}

bool isIndex(const Json& j) {
  return j.is_number_unsigned() || (j.is_number_integer() && j.get<std::int64_t>() >= 0);
}

// A node as the scene reader sees it: writes a one-node scene whose children (kept by the edit,
// not part of it) are placeholders, so the reader's rules for operators and warps hold.
Json nodeJson(const Node& n) {
  Scene scene;
  scene.root.kind = n.kind, scene.root.transform = n.transform, scene.root.id = n.id;
  if (!n.isPrimitive()) scene.root.children.assign(n.isWarp() ? 1 : 2, Node{});
  Json j = Json::parse(writeSceneJson(scene))["root"];
  j.erase("children");
  return j;
}

// Parses a node object through the scene reader; errors are renamed from /root to `pointer`.
Node parseNode(Json j, std::size_t placeholders, const std::string& source, const std::string& pointer) {
  if (placeholders) {
    Json kids = Json::array();
    for (std::size_t i = 0; i < placeholders; ++i) kids.push_back({{"type", "point"}});
    j["children"] = std::move(kids);
  }
  Json doc = Json::object();
  doc["blobvk"] = 1;
  doc["root"] = std::move(j);
  try {
    Node n = parseSceneJson(doc.dump(), source).root;
    if (placeholders) n.children.clear();
    return n;
  } catch (const SceneError& e) {
    std::string where = e.location();
    if (where.rfind("/root", 0) == 0) where = pointer + where.substr(5);
    throw SceneError(source, where, e.problem());
  }
}

class Resolver {
 public:
  Resolver(const EditScript& script, std::size_t i)
      : source_(script.source), at_("/edits/" + std::to_string(i)), j_(Json::parse(script.edits.at(i))) {}

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw SceneError(source_, at_ + key, problem);
  }

  NodePath path(const EditableTree& tree) const {
    if (j_.contains("node")) {
      const std::string id = j_["node"].get<std::string>();
      const std::vector<NodePath> found = tree.findAll(id, 2);
      if (found.empty()) fail("/node", "no node with id " + detail::quotedText(id));
      if (found.size() > 1)
        fail("/node", "the id " + detail::quotedText(id) + " names more than one node (" + toString(found[0]) + " and " +
                          toString(found[1]) + "): name the node by \"path\"");
      return found.front();
    }
    NodePath p;
    const Node* n = &tree.root();
    for (std::size_t k = 0; k < j_["path"].size(); ++k) {
      const std::size_t c = j_["path"][k].get<std::size_t>();
      if (c >= n->children.size())
        fail("/path/" + std::to_string(k), "the node at " + toString(p) + " has " +
                                               std::to_string(n->children.size()) + " children, no child " +
                                               std::to_string(c));
      p.push_back(c);
      n = &n->children[c];
    }
    return p;
  }

  Edit resolve(const EditableTree& tree) const {
    const NodePath p = path(tree);
    const Node& target = tree.node(p);
    if (j_.contains("remove")) {
      const std::size_t c = j_["remove"].get<std::size_t>();
      if (c >= target.children.size())
        fail("/remove", "the node at " + toString(p) + " has " + std::to_string(target.children.size()) +
                            " children, no child " + std::to_string(c));
      return {p, RemoveChild{c}};
    }
    if (j_.contains("add")) {
      if (!target.isOperator()) fail("/add", "children can be added to operators only; the node at " + toString(p) + " is not one");
      AddChild add;
      add.child = parseNode(j_["add"], 0, source_, at_ + "/add");
      refuseTakenIds(tree, add.child, "/add");
      if (j_.contains("at")) add.at = j_["at"].get<std::size_t>();
      if (add.at != std::size_t(-1) && add.at > target.children.size())
        fail("/at", "the node at " + toString(p) + " has " + std::to_string(target.children.size()) +
                        " children: a new one goes at 0.." + std::to_string(target.children.size()));
      return {p, std::move(add)};
    }
    // set: each key replaces the node's own (null: back to its default); a new "type" starts
    // from that type's defaults, keeping id and transform.
    const Json& set = j_["set"];
    Json j = nodeJson(target);
    if (set.contains("type") && set["type"] != j["type"]) {
      Json fresh = Json::object();
      for (const char* keep : {"id", "transform"})
        if (j.contains(keep)) fresh[keep] = j[keep];
      j = std::move(fresh);
    }
    for (const auto& [key, value] : set.items()) {
      if (key == "children") fail("/set/children", "set changes a node, not its children: use add and remove");
      if (value.is_null()) j.erase(key);
      else j[key] = value;
    }
    const std::string kindChange =
        "the node at " + toString(p) + " cannot change between primitive, operator and warp: remove it and add another";
    SetNode change;
    const std::size_t ownChildren = target.isPrimitive() ? 0 : target.isWarp() ? 1 : 2;
    try {
      change.node = parseNode(j, ownChildren, source_, at_ + "/set");
    } catch (const SceneError&) {
      // The placeholder children stand for the node's own. A new type of another kind refuses
      // them (or misses them), which is the kind change, not a key the script wrote: it is so
      // when the node parses with another kind's children.
      bool otherKindParses = false;
      for (std::size_t children : {0, 1, 2}) {
        if (children == ownChildren || !set.contains("type") || otherKindParses) continue;
        try {
          parseNode(j, children, source_, at_ + "/set");
          otherKindParses = true;
        } catch (const SceneError&) {
        }
      }
      if (otherKindParses) fail("/set/type", kindChange);
      throw;
    }
    if (change.node.kind.index() != target.kind.index()) fail("/set/type", kindChange);
    if (set.contains("id") && !change.node.id.empty() && change.node.id != target.id) {
      const std::vector<NodePath> taken = tree.findAll(change.node.id, 1);
      if (!taken.empty())
        fail("/set/id", "the node at " + toString(taken[0]) + " already has the id " + detail::quotedText(change.node.id) +
                            ": an id names one node");
    }
    return {p, std::move(change)};
  }

 private:
  // A new subtree's ids must not repeat one already in the tree (nor each other), or a later
  // edit naming that id would not know which node it means. One walk of each tree.
  void refuseTakenIds(const EditableTree& tree, const Node& subtree, const std::string& key) const {
    std::unordered_map<std::string, std::string> added;  // id -> its pointer in the edit
    std::vector<std::pair<const Node*, std::string>> todo{{&subtree, key}};
    while (!todo.empty()) {  // pre-order, children in order
      auto [n, pointer] = std::move(todo.back());
      todo.pop_back();
      if (!n->id.empty() && !added.emplace(n->id, pointer).second)
        fail(pointer + "/id", "the id " + detail::quotedText(n->id) + " is given twice in this edit: an id names one node");
      for (std::size_t c = n->children.size(); c-- > 0;) todo.emplace_back(&n->children[c], pointer + "/children/" + std::to_string(c));
    }
    if (added.empty()) return;
    std::vector<std::pair<const Node*, NodePath>> walk{{&tree.root(), {}}};
    while (!walk.empty()) {
      auto [n, path] = std::move(walk.back());
      walk.pop_back();
      if (const auto it = added.find(n->id); !n->id.empty() && it != added.end())
        fail(it->second + "/id", "the node at " + toString(path) + " already has the id " + detail::quotedText(n->id) +
                                     ": an id names one node");
      for (std::size_t c = n->children.size(); c-- > 0;) {
        NodePath q = path;
        q.push_back(c);
        walk.emplace_back(&n->children[c], std::move(q));
      }
    }
  }

  std::string source_, at_;
  Json j_;
};

}  // namespace

EditScript parseEditScript(std::string_view text, const std::string& sourceName) {
  refuseDuplicateKeys(text, sourceName);
  Json doc;
  try {
    doc = Json::parse(text.begin(), text.end());
  } catch (const Json::exception& e) {
    throw malformedJson(e, text, sourceName);
  }
  const auto fail = [&](const std::string& where, const std::string& problem) {
    throw SceneError(sourceName, where, problem);
  };
  if (!doc.is_object()) fail("/", "expected the edit script object at the top level, got " + typeOf(doc));
  for (const auto& [key, value] : doc.items())
    if (key != "blobvk_edits" && key != "edits") fail("/" + key, "unknown key (expected \"blobvk_edits\", \"edits\")");
  if (!doc.contains("blobvk_edits")) fail("/", "missing key \"blobvk_edits\" (the format version, 1)");
  if (doc["blobvk_edits"] != 1) fail("/blobvk_edits", "unsupported format version " + doc["blobvk_edits"].dump() + " (this reader understands 1)");
  if (!doc.contains("edits")) fail("/", "missing key \"edits\"");
  const Json& edits = doc["edits"];
  if (!edits.is_array()) fail("/edits", "expected an array of edits, got " + typeOf(edits));
  if (edits.empty()) fail("/edits", "no edits");
  EditScript script{sourceName, {}};
  for (std::size_t i = 0; i < edits.size(); ++i) {
    const Json& e = edits[i];
    const std::string at = "/edits/" + std::to_string(i);
    if (!e.is_object()) fail(at, "expected an edit object, got " + typeOf(e));
    for (const auto& [key, value] : e.items())
      if (key != "node" && key != "path" && key != "set" && key != "add" && key != "at" && key != "remove")
        fail(at + "/" + key, "unknown key (expected \"node\" or \"path\", and \"set\", \"add\" [+ \"at\"] or \"remove\")");
    if (e.contains("node") == e.contains("path")) fail(at, "name the node by exactly one of \"node\" (an id) and \"path\" (child indices)");
    if (e.contains("node") && (!e["node"].is_string() || e["node"].get<std::string>().empty()))
      fail(at + "/node", "expected a non-empty id string, got " + typeOf(e["node"]));
    if (e.contains("path")) {
      if (!e["path"].is_array()) fail(at + "/path", "expected an array of child indices, got " + typeOf(e["path"]));
      for (std::size_t k = 0; k < e["path"].size(); ++k)
        if (!isIndex(e["path"][k])) fail(at + "/path/" + std::to_string(k), "expected a child index (an integer >= 0)");
    }
    const int changes = int(e.contains("set")) + int(e.contains("add")) + int(e.contains("remove"));
    if (changes != 1) fail(at, "give exactly one of \"set\", \"add\" and \"remove\"");
    if (e.contains("set") && (!e["set"].is_object() || e["set"].empty()))
      fail(at + "/set", "expected an object of node keys to change");
    if (e.contains("add") && !e["add"].is_object()) fail(at + "/add", "expected a node object, got " + typeOf(e["add"]));
    if (e.contains("remove") && !isIndex(e["remove"])) fail(at + "/remove", "expected a child index (an integer >= 0)");
    if (e.contains("at") && !e.contains("add")) fail(at + "/at", "\"at\" goes with \"add\"");
    if (e.contains("at") && !isIndex(e["at"])) fail(at + "/at", "expected a child index (an integer >= 0)");
    script.edits.push_back(e.dump());
  }
  return script;
}

EditScript readEditScript(const std::string& path) {
  return parseEditScript(detail::readWholeFile(path), path);
}

Edit resolveEdit(const EditScript& script, std::size_t i, const EditableTree& tree) {
  return Resolver(script, i).resolve(tree);
}

Region applyScriptEdit(const EditScript& script, std::size_t i, EditableTree& tree) {
  const Edit edit = resolveEdit(script, i, tree);
  try {
    return tree.apply(edit);
  } catch (const std::invalid_argument& e) {
    throw SceneError(script.source, "/edits/" + std::to_string(i), e.what());
  }
}

std::string describeEdit(const EditScript& script, std::size_t i) {
  const Json j = Json::parse(script.edits.at(i));
  const std::string node = j.contains("node") ? "'" + j["node"].get<std::string>() + "'" : j["path"].dump();
  if (j.contains("add")) return "add to " + node;
  if (j.contains("remove")) return "remove child " + j["remove"].dump() + " of " + node;
  std::string keys;
  for (const auto& [key, value] : j["set"].items()) keys += (keys.empty() ? "" : ",") + key;
  return "set " + keys + " of " + node;
}

}  // namespace blobvk::blobtree
