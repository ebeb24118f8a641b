#include "blobvk/vk/eval/codegen_text.h"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace blobvk::vk::codegen {

std::string lit(float v) {
  if (!std::isfinite(v)) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, 4);
    char buf[40];
    std::snprintf(buf, sizeof buf, "uintBitsToFloat(0x%08xu)", bits);
    return buf;
  }
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", double(v));
  std::string s = buf;
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

std::string vec3Lit(const layout::vec4& v) { return "vec3(" + lit(v.x) + ", " + lit(v.y) + ", " + lit(v.z) + ")"; }
std::string vec4Lit(const layout::vec4& v) {
  return "vec4(" + lit(v.x) + ", " + lit(v.y) + ", " + lit(v.z) + ", " + lit(v.w) + ")";
}

layout::vec4 Word::value() const {
  layout::vec4 v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}
std::string Word::v4() const { return load.empty() ? vec4Lit(value()) : "uintBitsToFloat(" + load + ")"; }
std::string Word::v3() const { return load.empty() ? vec3Lit(value()) : "uintBitsToFloat(" + load + ".xyz)"; }
std::string Word::x() const { return load.empty() ? lit(value().x) : "uintBitsToFloat(" + load + ".x)"; }
std::string Word::y() const { return load.empty() ? lit(value().y) : "uintBitsToFloat(" + load + ".y)"; }
std::string Word::w() const { return load.empty() ? lit(value().w) : "uintBitsToFloat(" + load + ".w)"; }
std::string Word::colour() const { return load.empty() ? std::to_string(bits.x) + "u" : load + ".x"; }

std::string primitiveField(std::uint32_t type, const std::string& at, const Word& p0, const Word& p1, const Word& p2) {
  const std::string c = p0.v3();
  switch (type) {
    case layout::PRIM_POINT: return "wyvill(ddPoint(" + at + ", " + c + "))";
    case layout::PRIM_LINE: return "wyvill(ddLine(" + at + ", " + c + ", " + p1.v4() + "))";
    case layout::PRIM_CYLINDER:
      return "wyvill(ddCylinder(" + at + ", " + c + ", " + p1.v3() + ", " + p2.x() + ", " + p2.y() + "))";
    case layout::PRIM_DISC: return "wyvill(ddDisc(" + at + ", " + c + ", " + p1.v3() + ", " + p2.x() + "))";
    case layout::PRIM_RING: return "wyvill(ddRing(" + at + ", " + c + ", " + p1.v3() + ", " + p2.x() + "))";
    case layout::PRIM_CUBE: return "wyvill(ddCube(" + at + ", " + c + ", " + p1.v3() + "))";
    case layout::PRIM_TRIANGLE:
      return "wyvill(triangleDistance2(" + at + ", " + c + ", " + p1.v3() + ", " + p2.v3() + "))";
    case layout::PRIM_QUADRIC: return "quadricField(" + at + ", " + c + ", " + p0.w() + ")";
    default: return "wyvill(1.0)";  // the interpreter's "no field for an unknown type"
  }
}

std::string warpPoint(std::uint32_t type, std::uint32_t a, std::uint32_t b, const std::string& at, const Word& params) {
  const std::string sa = std::to_string(a) + "u", sb = std::to_string(b) + "u";
  switch (type) {
    case layout::WARP_TWIST: return "warpTwist(" + at + ", " + sa + ", " + params.x() + ")";
    case layout::WARP_TAPER: return "warpTaper(" + at + ", " + sa + ", " + sb + ", " + params.x() + ")";
    case layout::WARP_SHEAR: return "warpShear(" + at + ", " + sa + ", " + sb + ", " + params.x() + ")";
    case layout::WARP_BEND: return "warpBend(" + at + ", " + sa + ", " + sb + ", " + params.v4() + ")";
    default: return at;
  }
}

std::string toLocal(const Word& r0, const Word& r1, const Word& r2, const std::string& at) {
  return "toLocalRows(" + r0.v4() + ", " + r1.v4() + ", " + r2.v4() + ", " + at + ")";
}

std::string combineLines(std::uint32_t op, const std::string& d, const std::string& c, const std::string& b,
                         const std::string& cb, bool colour, const std::string& in) {
  std::string s;
  auto line = [&](const std::string& t) { s += in + t + "\n"; };
  if (op == layout::OP_ADD) {
    if (colour)
      line("{ float wa = max(" + d + ", 0.0), wb = max(" + b + ", 0.0); float w = wa + wb; if (w > 0.0) " + c + " = (" +
           c + " * wa + " + cb + " * wb) / w; }");
    line(d + " = " + d + " + " + b + ";");
  } else if (op == layout::OP_MAX) {
    if (colour) line("if (" + b + " > " + d + ") " + c + " = " + cb + ";");
    line(d + " = max(" + d + ", " + b + ");");
  } else if (op == layout::OP_MIN) {
    if (colour) line("if (" + b + " < " + d + ") " + c + " = " + cb + ";");
    line(d + " = min(" + d + ", " + b + ");");
  } else if (op == layout::OP_DIFF) {
    line("{ float cut = 1.0 - " + b + ";");
    if (colour) line("  if (cut < " + d + ") " + c + " = " + cb + ";");
    line("  " + d + " = min(" + d + ", cut); }");
  } else if (op == layout::OP_SDIFF) {
    line("{ float keep = 1.0 - " + b + ";");
    if (colour) line("  if (keep < " + d + ") " + c + " = " + cb + ";");
    line("  " + d + " = " + d + " * keep; }");
  } else {  // OP_MUL
    if (colour) line("if (" + b + " < " + d + ") " + c + " = " + cb + ";");
    line(d + " = " + d + " * " + b + ";");
  }
  return s;
}

std::string unaryLine(std::uint32_t op, const std::string& d, std::uint32_t w) {
  if (op == layout::OP_ONE_MINUS) return d + " = 1.0 - " + d + ";";
  float e;
  std::memcpy(&e, &w, 4);
  return d + " = powField(" + d + ", " + lit(e) + ");";  // shaders/eval_formulas.glsl
}

}  // namespace blobvk::vk::codegen
