// The BlobTree as a user edits it: skeletal primitives, operators and warps in a tree, each node
// with an optional affine transform. Evaluators never walk this; they run a compiled Program
// (see program.h). All values are in double; compile() rounds to the float records.
#pragma once

#include <glm/vec3.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace blobvk::blobtree {

using Vec3 = glm::dvec3;
using Quat = glm::dquat;

// Same numbering as layout::PRIM_* so compile() can cast.
enum class PrimitiveType : std::uint32_t {
  Point = 0,
  Line = 1,
  Cylinder = 2,
  Disc = 3,
  Ring = 4,
  Cube = 5,
  Triangle = 6,
  QuadricPoint = 7,
};

enum class OperatorType : std::uint32_t {
  Blend,             // sum of children
  Ricci,             // (sum f_i^n)^(1/n)
  Union,             // max
  Intersection,      // min
  Difference,        // min(f_1, 1 - f_2, 1 - f_3, ...)
  SmoothDifference,  // f_1 * (1 - f_2) * (1 - f_3) ...
};

// Same numbering as layout::WARP_*.
enum class WarpType : std::uint32_t { Twist = 0, Taper = 1, Bend = 2, Shear = 3 };

// Affine transform: p_parent = translate + rotate * (scale * p_local).
struct Transform {
  Vec3 translate{0.0};
  Quat rotate{1.0, 0.0, 0.0, 0.0};  // w, x, y, z (GLM order)
  Vec3 scale{1.0};

  bool isIdentity() const;
};

// Skeleton parameters; which fields matter depends on the type (see docs/scene-format.md).
// `support` is the kernel's radius of influence R: the field is (1 - d^2/R^2)^3.
struct Primitive {
  PrimitiveType type = PrimitiveType::Point;
  Vec3 a{0.0};           // centre / start / base / corner 0
  Vec3 b{0.0};           // end (line) / axis or normal / half extents (cube) / corner 1
  Vec3 c{0.0};           // corner 2 (triangle)
  double radius = 0.0;   // cylinder, disc, ring
  double height = 0.0;   // cylinder
  double scale = 1.0;    // quadric point: peak field value S
  double support = 1.0;  // kernel support radius R (> 0)
  Vec3 colour{0.8, 0.8, 0.8};
};

struct Operator {
  OperatorType type = OperatorType::Blend;
  double power = 2.0;  // Ricci exponent n (> 0)
};

struct Warp {
  WarpType type = WarpType::Twist;
  int axis = 2;          // twist: axis; taper: base axis a; bend: length axis; shear: sheared axis
  int otherAxis = 0;     // taper: tapered axis b; bend: bend-towards axis; shear: dependent axis
  double factor = 0.0;   // twist rad/unit, taper slope, shear factor, bend rate (rad/unit)
  double centre = 0.0;   // bend only
  double lo = -1e30;     // bend region along the length axis
  double hi = 1e30;
};

struct Node {
  std::variant<Primitive, Operator, Warp> kind;
  std::string id;  // optional, for error messages and instancing
  Transform transform;
  std::vector<Node> children;  // operators: >= 1 (difference: >= 2); warps: exactly 1

  bool isPrimitive() const { return std::holds_alternative<Primitive>(kind); }
  bool isOperator() const { return std::holds_alternative<Operator>(kind); }
  bool isWarp() const { return std::holds_alternative<Warp>(kind); }
};

// Optional sections of a scene file that describe how to view and sample it.
struct Camera {
  std::optional<Vec3> eye, target, up;
  std::optional<double> azimuthDeg, elevationDeg, distance;
  double fovYDeg = 45.0;
};

struct GridSettings {
  std::optional<double> cellSize;
  std::optional<int> resolution;  // cells along the longest side of the bounds
  std::optional<Vec3> boundsLo, boundsHi;
};

struct Scene {
  Node root;
  std::optional<Camera> camera;
  GridSettings grid;
  std::string name;
  // The "simulation" section (FEM, tools, cutting), kept as JSON text: blobtree knows nothing
  // of simulation; surgery/scene_config.cpp validates it. Empty when absent.
  std::string simulationJson;
};

// Statistics used by `blobvk info`.
struct TreeStats {
  std::size_t primitives = 0, operators = 0, warps = 0, depth = 0;
};
TreeStats treeStats(const Node& root);

const char* toString(PrimitiveType t);
const char* toString(OperatorType t);
const char* toString(WarpType t);

}  // namespace blobvk::blobtree
