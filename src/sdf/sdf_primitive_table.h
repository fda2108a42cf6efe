// # implicit: the table of SDF primitives
//
// Every primitive is listed once here, as libfive lists its opcodes
// (tree/opcode.hpp): the enum, the name table, the JSON loader, evaluation,
// bounds and Lipschitz factors are all generated from
// IMPLICIT_SDF_PRIMITIVES, so that `-Wswitch` and the table test
// (sdf_primitives_test.cpp) cover every primitive. Adding one means a row
// here and, in sdf_primitives.h, its block of definitions:
//
//   sd_<id>(p, ...)                the distance formula
//   sdf_params_<id>                its JSON parameters (key -> sdf_node field)
//   eval_<id>(node, p)             the formula on a node's fields
//   bounds_<id>(node)              box of its zero set (and inside), local
//   lipschitz_<id>(node)           its Lipschitz factor (1 if exact)
//   check_<id>(node)               checks across parameters (sdf_no_problem)
//
// The rows keep the seed's order (its six types first): the enum's values
// and the names follow it.
#pragma once

#include <array>
#include <string>

namespace implicit {

// X(id, JSON name) for each primitive.
#define IMPLICIT_SDF_PRIMITIVES(X) \
  X(box, "box")                    \
  X(bbox, "bbox")                  \
  X(sphere, "sphere")              \
  X(torus, "torus")                \
  X(capped_cone, "capped_cone")    \
  X(plane, "plane")                \
  X(capsule, "capsule")            \
  X(cylinder, "cylinder")          \
  X(rounded_box, "rounded_box")    \
  X(ellipsoid, "ellipsoid")        \
  X(octahedron, "octahedron")

// X(id, JSON name) for each operator (their parameters and operands are read
// by scene_io.cpp, their evaluation is the tape's).
#define IMPLICIT_SDF_OPERATORS(X)                  \
  X(op_union, "union")                             \
  X(op_intersection, "intersection")               \
  X(op_subtraction, "subtraction")                 \
  X(op_smooth_union, "smooth_union")               \
  X(op_smooth_intersection, "smooth_intersection") \
  X(op_smooth_subtraction, "smooth_subtraction")   \
  X(op_round, "round")                             \
  X(op_onion, "onion")                             \
  X(op_transform, "transform")

// X(id, JSON name) for each domain operator: the operand is evaluated at a
// warped point q(p), as in Inigo Quilez's catalogue (sdf_program.h gives
// each map and its node fields).
#define IMPLICIT_SDF_WARPS(X) \
  X(op_twist, "twist")        \
  X(op_bend, "bend")          \
  X(op_repeat, "repeat")      \
  X(op_elongate, "elongate")  \
  X(op_mirror, "mirror")

// X(id, name, operands) for each arithmetic clause of closed-form
// expressions; the names are the opcodes of fidget's `.vm` text format
// (sdf_program.h gives each one's value, NaN rules included). Math nodes are
// no JSON types: scenes write them as `expression` strings or `.vm` files.
#define IMPLICIT_SDF_MATH(X)    \
  X(math_const, "const", 0)     \
  X(math_x, "var-x", 0)         \
  X(math_y, "var-y", 0)         \
  X(math_z, "var-z", 0)         \
  X(math_neg, "neg", 1)         \
  X(math_abs, "abs", 1)         \
  X(math_square, "square", 1)   \
  X(math_sqrt, "sqrt", 1)       \
  X(math_exp, "exp", 1)         \
  X(math_log, "ln", 1)          \
  X(math_sin, "sin", 1)         \
  X(math_cos, "cos", 1)         \
  X(math_tan, "tan", 1)         \
  X(math_asin, "asin", 1)       \
  X(math_acos, "acos", 1)       \
  X(math_atan, "atan", 1)       \
  X(math_floor, "floor", 1)     \
  X(math_ceil, "ceil", 1)       \
  X(math_round, "round", 1)     \
  X(math_not, "not", 1)         \
  X(math_add, "add", 2)         \
  X(math_sub, "sub", 2)         \
  X(math_mul, "mul", 2)         \
  X(math_div, "div", 2)         \
  X(math_min, "min", 2)         \
  X(math_max, "max", 2)         \
  X(math_atan2, "atan2", 2)     \
  X(math_mod, "mod", 2)         \
  X(math_compare, "compare", 2) \
  X(math_and, "and", 2)         \
  X(math_or, "or", 2)

// `case sdf_type::id:` for each primitive, for switches that treat them
// alike.
#define IMPLICIT_SDF_PRIMITIVE_CASE(id, name) case sdf_type::id:
#define IMPLICIT_SDF_PRIMITIVE_CASES \
  IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_PRIMITIVE_CASE)
// The same for each CSG operator, each domain operator and each math clause.
#define IMPLICIT_SDF_CSG_CASES \
  IMPLICIT_SDF_OPERATORS(IMPLICIT_SDF_PRIMITIVE_CASE)
#define IMPLICIT_SDF_WARP_CASES IMPLICIT_SDF_WARPS(IMPLICIT_SDF_PRIMITIVE_CASE)
#define IMPLICIT_SDF_MATH_CASE(id, name, operands) case sdf_type::id:
#define IMPLICIT_SDF_MATH_CASES IMPLICIT_SDF_MATH(IMPLICIT_SDF_MATH_CASE)
// Every node that is not a primitive.
#define IMPLICIT_SDF_OPERATOR_CASES \
  IMPLICIT_SDF_CSG_CASES IMPLICIT_SDF_WARP_CASES IMPLICIT_SDF_MATH_CASES

// -----------------------------------------------------------------------------
// PARAMETERS
// -----------------------------------------------------------------------------

// The sdf_node field a parameter fills; `size` is a vec3, the others floats.
enum class sdf_param_field { size, radius, radius2, height, thickness };

// The range a parameter must lie in (every component for `size`).
enum class sdf_param_range { positive, non_negative };

// One JSON parameter of a primitive; all are required.
struct sdf_param {
  const char*     key   = "";
  sdf_param_field field = sdf_param_field::radius;
  sdf_param_range range = sdf_param_range::positive;
};

// The parameters of one primitive, in the order the loader reads them (the
// first missing or bad one is reported).
struct sdf_param_list {
  const sdf_param* data  = nullptr;
  int              count = 0;
  const sdf_param* begin() const { return data; }
  const sdf_param* end() const { return data + count; }
};

template <size_t count>
inline sdf_param_list make_param_list(
    const std::array<sdf_param, count>& params) {
  return {params.data(), (int)count};
}

// A problem across parameters, found after each is in range: the key to
// blame and what is wrong; no problem when `key` is null.
struct sdf_param_problem {
  const char* key     = nullptr;
  std::string problem = "";
};

}  // namespace implicit
