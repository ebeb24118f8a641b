#include "blobvk/vk/eval/runtime_compiler.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/shader_sources.h"

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>

#include <atomic>
#include <memory>
#include <mutex>

namespace blobvk::vk {
namespace {

// Serves #include "name" from the overrides, then from the embedded shader sources.
class EmbeddedIncluder : public glslang::TShader::Includer {
 public:
  explicit EmbeddedIncluder(const std::map<std::string, std::string>& overrides) : overrides_(overrides) {}

  IncludeResult* includeLocal(const char* name, const char*, std::size_t) override { return resolve(name); }
  IncludeResult* includeSystem(const char* name, const char*, std::size_t) override { return resolve(name); }
  void releaseInclude(IncludeResult* result) override { delete result; }

 private:
  IncludeResult* resolve(const std::string& name) {
    if (auto it = overrides_.find(name); it != overrides_.end())
      return new IncludeResult(name, it->second.data(), it->second.size(), nullptr);
    if (auto text = shaderSource(name)) return new IncludeResult(name, text->data(), text->size(), nullptr);
    return nullptr;  // glslang reports the missing include with the requesting file and line
  }
  const std::map<std::string, std::string>& overrides_;
};

std::atomic<std::uint32_t> initialisations{0};

// glslang keeps process-wide tables: initialise once, never finalise (other threads may compile).
void initialiseGlslang() {
  static std::once_flag once;
  std::call_once(once, [] {
    glslang::InitializeProcess();
    ++initialisations;
  });
}

}  // namespace

std::uint32_t glslangInitialisations() { return initialisations.load(); }

std::vector<std::uint32_t> compileComputeShader(const std::string& shaderFile,
                                                const std::map<std::string, std::string>& overrides) {
  std::string source;
  if (auto it = overrides.find(shaderFile); it != overrides.end()) {
    source = it->second;
  } else if (auto text = shaderSource(shaderFile)) {
    source = std::string(*text);
  } else {
    throw VulkanError("no embedded shader source named '" + shaderFile + "'");
  }
  initialiseGlslang();
  glslang::TShader shader(EShLangCompute);
  const char* text = source.c_str();
  const int length = int(source.size());
  const char* name = shaderFile.c_str();
  shader.setStringsWithLengthsAndNames(&text, &length, &name, 1);
  shader.setEnvInput(glslang::EShSourceGlsl, EShLangCompute, glslang::EShClientVulkan, 100);
  shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_1);
  shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_3);
  EmbeddedIncluder includer(overrides);
  const auto messages = EShMessages(EShMsgSpvRules | EShMsgVulkanRules);
  if (!shader.parse(GetDefaultResources(), 450, ENoProfile, false, false, messages, includer))
    throw VulkanError("compiling " + shaderFile + " at run time failed: " + shader.getInfoLog());
  glslang::TProgram program;
  program.addShader(&shader);
  if (!program.link(messages)) throw VulkanError("linking " + shaderFile + " at run time failed: " + program.getInfoLog());
  std::vector<unsigned> words;
  glslang::SpvOptions options;
  options.disableOptimizer = true;  // the driver optimises anyway (NIR + LLVM on llvmpipe)
  glslang::GlslangToSpv(*program.getIntermediate(EShLangCompute), words, &options);
  return {words.begin(), words.end()};
}

}  // namespace blobvk::vk
