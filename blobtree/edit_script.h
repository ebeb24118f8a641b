// Edit scripts (docs/editing.md): a JSON list of edits applied in order, each naming its node by
// id or by a path of child indices. The document is checked when read; each edit is resolved
// against the tree as it is when its turn comes (an id may name a node an earlier edit added).
// Every problem is a SceneError "<file>: /edits/<i>/<key>...: <problem>".
#pragma once

#include "blobvk/blobtree/edit.h"

#include <string>
#include <string_view>
#include <vector>

namespace blobvk::blobtree {

struct EditScript {
  std::string source;              // file name for messages
  std::vector<std::string> edits;  // each edit's JSON, compact, in order
};

EditScript parseEditScript(std::string_view text, const std::string& sourceName);
EditScript readEditScript(const std::string& path);

// Edit i as an Edit on `tree`. Throws SceneError naming the JSON pointer at fault.
Edit resolveEdit(const EditScript& script, std::size_t i, const EditableTree& tree);

// Applies edit i (resolveEdit, then tree.apply); a change the tree refuses (a tree that no
// longer compiles, a difference left with one child) is a SceneError at "/edits/<i>" too.
Region applyScriptEdit(const EditScript& script, std::size_t i, EditableTree& tree);

// One line for listings: "move 'pillar' [0, 3]", "add to [0]", ...
std::string describeEdit(const EditScript& script, std::size_t i);

}  // namespace blobvk::blobtree
