// GLSL text pieces shared by the specialised code generators (program_codegen.cpp unrolls,
// program_codegen_loops.cpp emits shared functions and loops): exact float literals, record
// values that are either literals or loaded from the data buffer, and one statement form per
// opcode, so both generators call the formulas of shaders/eval_formulas.glsl the same way.
#pragma once

#include "blobvk/shaders/program_layout.h"

#include <cstdint>
#include <string>

namespace blobvk::vk::codegen {

// A float literal that parses back to exactly `v` (non-finite values as their bits).
std::string lit(float v);
std::string vec3Lit(const layout::vec4& v);
std::string vec4Lit(const layout::vec4& v);

// A 16-byte record word: a literal, or `load` (a uvec4 expression, e.g. "D[12u + b]").
struct Word {
  layout::uvec4 bits{};
  std::string load;  // empty: literal
  layout::vec4 value() const;
  std::string v4() const;
  std::string v3() const;
  std::string x() const;  // a float component
  std::string y() const;
  std::string w() const;
  std::string colour() const;  // .x as a uint
};

// The field of a primitive of `type` at point expression `at`; p0..p2 its skeleton words.
std::string primitiveField(std::uint32_t type, const std::string& at, const Word& p0, const Word& p1, const Word& p2);
// The warped point; params its parameter word, axes a and b.
std::string warpPoint(std::uint32_t type, std::uint32_t a, std::uint32_t b, const std::string& at, const Word& params);
// toLocalRows of the point by a matrix's three row words.
std::string toLocal(const Word& r0, const Word& r1, const Word& r2, const std::string& at);

// The statements of combine opcode `op` (OP_ADD ... OP_MUL): d = op(d, b), colours cd, cb when
// `colour`. Each statement is one line, without indentation.
std::string combineLines(std::uint32_t op, const std::string& d, const std::string& cd, const std::string& b,
                         const std::string& cb, bool colour, const std::string& indent);
// OP_ONE_MINUS and OP_POW (exponent bits `w`) on register d.
std::string unaryLine(std::uint32_t op, const std::string& d, std::uint32_t w);

}  // namespace blobvk::vk::codegen
