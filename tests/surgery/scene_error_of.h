// The SceneError a reader throws, for tests of its messages; a test failure when it throws none.
#pragma once

#include "blobvk/blobtree/scene_error.h"

#include <gtest/gtest.h>

#include <string>

namespace blobvk::surgery {

template <class Read>
blobtree::SceneError sceneErrorOf(Read read, const std::string& input) {
  try {
    read();
  } catch (const blobtree::SceneError& e) {
    return e;
  }
  ADD_FAILURE() << "no error for " << input;
  return blobtree::SceneError("", "", "");
}

}  // namespace blobvk::surgery
