// Code options for tests of the generated gradient's paths (the vertex pass per field tile, its
// background builds): the device's options with CPU drivers' loop rule, so that short programs
// are unrolled on every driver. GPUs loop any repeated shape (defaultCodegenOptions), and looped
// code generates no gradient: a tower's vertex pass there interprets it instead.
#pragma once

#include "blobvk/vk/eval/gpu_program.h"

namespace blobvk::testing {

inline vk::CodegenOptions unrolledCodegen(const vk::Device& device) {
  vk::CodegenOptions c = vk::defaultCodegenOptions(device);
  c.loops = vk::defaultCodegenOptions(true).loops;  // on lavapipe: the default itself
  return c;
}

}  // namespace blobvk::testing
