// The blobvk JSON scene format (docs/scene-format.md): a model tree plus optional camera and
// grid sections. Readers validate strictly and throw SceneError naming the JSON pointer at fault.
#pragma once

#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/tree.h"

#include <exception>

#include <string>
#include <string_view>

namespace blobvk::blobtree {

// Parses a scene from JSON text; `sourceName` is used in error messages (a path or "<memory>").
// Instances are expanded, so the returned tree holds only primitives, operators and warps.
Scene parseSceneJson(std::string_view text, const std::string& sourceName);

// Throws SceneError naming `source` and the JSON pointer of the first key an object repeats (a
// JSON parser keeps one of them without a word); returns quietly on malformed JSON, for the
// parse that follows to report. Linear in the text. For every JSON file blobvk reads.
void refuseDuplicateKeys(std::string_view text, const std::string& source);

// The one-line error for JSON text the parser refused (`parseFailure`, what nlohmann::json::parse
// threw): "line L, column C: malformed JSON: <problem>", for every JSON file blobvk reads.
SceneError malformedJson(const std::exception& parseFailure, std::string_view text, const std::string& source);

// Reads and parses a .json file; an unreadable file is a SceneError too.
Scene readSceneJson(const std::string& path);

// Serialises a scene; parseSceneJson(writeSceneJson(s)) gives back an equal tree.
// Throws std::invalid_argument for a tree no reader would accept (a warp axis out of range).
std::string writeSceneJson(const Scene& scene);

}  // namespace blobvk::blobtree
