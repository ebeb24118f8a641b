// SPIR-V of the kernels compiled at run time (the specialised evaluators), cached on disk beside
// the pipeline cache: lavapipe's VkPipelineCache stores nothing, so without this every process
// runs glslang on every generated kernel again. One file per kernel source:
// "spirv-<hash>.spv", keyed by a hash of the GLSL (the shader's name, the generated overrides),
// every embedded shader source, glslang's version and blobvk's version; a second, independent
// hash and the key's length in the file's header catch a collision of the first.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace blobvk::vk {

// What compileComputeShaderCached did in this process (all threads): tests and `bench`.
struct SpirvCacheCounters {
  std::uint64_t hits = 0;      // SPIR-V read from a cache file
  std::uint64_t compiles = 0;  // glslang runs (no cache, a miss, or an unusable file)
  std::uint64_t ignored = 0;   // files ignored as corrupt, truncated or foreign
};
SpirvCacheCounters spirvCacheCounters();

// The cache file in `dir` for this source.
std::filesystem::path spirvCacheFile(const std::filesystem::path& dir, const std::string& shaderFile,
                                     const std::map<std::string, std::string>& overrides);

// compileComputeShader (vk/eval/runtime_compiler.h) through the cache in `dir` (empty: no cache).
// A missing file is compiled and written (temporary file + rename, so concurrent processes see
// the old file or the new one); an unreadable, truncated, corrupt or foreign file gives one
// warning line on stderr, is compiled again and replaced. Failing to write is one warning line
// per process, never an error.
std::vector<std::uint32_t> compileComputeShaderCached(const std::filesystem::path& dir, const std::string& shaderFile,
                                                      const std::map<std::string, std::string>& overrides);

}  // namespace blobvk::vk
