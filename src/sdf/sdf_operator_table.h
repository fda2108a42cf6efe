// # implicit: the table of SDF operators
//
// Every JSON `type` of an sdfunction that is not a primitive is one row
// here, as the primitives are rows of sdf_primitive_table.h: its keys (each
// with its JSON value, range and help), how it becomes nodes and what it
// does. The scene loader reads operators through it (scene_io_sdf.cpp), the
// Python module exports it (its methods check their arguments by it and show
// its help), `ysdf types` prints it. The domain operators and their keys
// follow Inigo Quilez's catalogue (iquilezles.org/articles/distfunctions):
// opTwist and opCheapBend's `k`, opElongate's `h`, opRepetition's spacing
// `s` and opLimitedRepetition's limit `l` (here `spacing` and `limit`),
// the opSym* symmetries, opDisplace.
//
// Math clauses are no JSON types: scenes write them as `expression` strings
// or `.vm` files (sdf_expression.h, sdf_vm_io.h), so "add" is no type and
// "round" is the CSG rounding.
#pragma once

#include <string>
#include <vector>

#include "sdf_program.h"

namespace implicit {

// The JSON value of an operator's key.
enum class sdf_key_type {
  operand,       // one nested sdfunction object
  operand_list,  // an array of 2 or more nested sdfunction objects
  operand_map,   // an object of nested sdfunction objects under names
  number,        // a finite number
  vec3,          // an array of 3 finite numbers
  counts,        // an array of 3 integers
  axes,          // a string of distinct letters among x, y, z
  expression,    // an infix formula (sdf_expression.h)
  uri,           // a `.vm` file, relative to the scene file
  box,           // [[x0, y0, z0], [x1, y1, z1]] with x0 < x1, ...
};

// How each key type is written, for messages and help.
inline const std::vector<std::string> sdf_key_type_names = {"object",
    "array of objects", "object of named objects", "number",
    "array of 3 numbers", "array of 3 integers", "string of axes", "string",
    "string (a file)", "array of 2 points"};

// The range a number (each component of an array) must lie in.
enum class sdf_key_range { any, positive, non_negative };

// The sdf_node field a key fills; `none`: read by the operator's builder.
enum class sdf_key_field {
  none,
  blend,
  radius,
  thickness,
  value,
  size,
  count,
  axes
};

// One key of an operator.
struct sdf_operator_key {
  const char*   key      = "";
  sdf_key_type  type     = sdf_key_type::number;
  sdf_key_range range    = sdf_key_range::any;
  sdf_key_field field    = sdf_key_field::none;
  bool          required = true;
  const char*   help     = "";
};

// How an operator's object becomes nodes.
enum class sdf_operator_build {
  fold,        // its node combines the operands (fold_sdf_operands)
  unary,       // its node over the operand
  transform,   // the operand in the object's frame (a frame is required)
  expression,  // a formula or `.vm` file over named operands, clipped to
               // `bounds` (an intersection with a box)
  displace,    // math add of the operand and a formula in its space
};

// One JSON type that is not a primitive.
struct sdf_operator {
  const char*                   name  = "";
  sdf_type                      type  = sdf_type::op_union;  // fold, unary
  sdf_operator_build            build = sdf_operator_build::unary;
  std::vector<sdf_operator_key> keys  = {};  // in the order they are read
  const char*                   help  = "";
};

// The rows, in the order of the JSON types after the primitives.
// clang-format off
inline const std::vector<sdf_operator> sdf_operators = {
  {"union", sdf_type::op_union, sdf_operator_build::fold,
    {{"operands", sdf_key_type::operand_list, sdf_key_range::any,
      sdf_key_field::none, true, "the shapes, folded left"}},
    "min of the operands"},
  {"intersection", sdf_type::op_intersection, sdf_operator_build::fold,
    {{"operands", sdf_key_type::operand_list, sdf_key_range::any,
      sdf_key_field::none, true, "the shapes, folded left"}},
    "max of the operands"},
  {"subtraction", sdf_type::op_subtraction, sdf_operator_build::fold,
    {{"operands", sdf_key_type::operand_list, sdf_key_range::any,
      sdf_key_field::none, true, "the first shape, then those removed"}},
    "the first operand minus the others"},
  {"smooth_union", sdf_type::op_smooth_union, sdf_operator_build::fold,
    {{"operands", sdf_key_type::operand_list, sdf_key_range::any,
      sdf_key_field::none, true,
      "the shapes, in any order (the same function)"},
     {"blend", sdf_key_type::number, sdf_key_range::positive,
      sdf_key_field::blend, true, "blend radius"}},
    "polynomial smooth minimum of the operands, folded over their "
    "values in increasing order"},
  {"smooth_intersection", sdf_type::op_smooth_intersection,
    sdf_operator_build::fold,
    {{"operands", sdf_key_type::operand_list, sdf_key_range::any,
      sdf_key_field::none, true,
      "the shapes, paired into a balanced tree in list order"},
     {"blend", sdf_key_type::number, sdf_key_range::positive,
      sdf_key_field::blend, true, "blend radius"}},
    "polynomial smooth maximum of the operands"},
  {"smooth_subtraction", sdf_type::op_smooth_subtraction,
    sdf_operator_build::fold,
    {{"operands", sdf_key_type::operand_list, sdf_key_range::any,
      sdf_key_field::none, true, "the first shape, then those removed"},
     {"blend", sdf_key_type::number, sdf_key_range::positive,
      sdf_key_field::blend, true, "blend radius"}},
    "the first operand smoothly minus the others"},
  {"round", sdf_type::op_round, sdf_operator_build::unary,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape"},
     {"radius", sdf_key_type::number, sdf_key_range::positive,
      sdf_key_field::radius, true, "thickness added all around"}},
    "d - radius: grown, its edges rounded (IQ's opRound)"},
  {"onion", sdf_type::op_onion, sdf_operator_build::unary,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape"},
     {"thickness", sdf_key_type::number, sdf_key_range::positive,
      sdf_key_field::thickness, true, "half the shell's thickness"}},
    "|d| - thickness: a shell about the surface (IQ's opOnion)"},
  {"transform", sdf_type::op_transform, sdf_operator_build::transform,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape"}},
    "the operand in the object's frame or world_from_local (required)"},
  {"twist", sdf_type::op_twist, sdf_operator_build::unary,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape"},
     {"k", sdf_key_type::number, sdf_key_range::any, sdf_key_field::value,
      true, "radians of turn per unit of height"}},
    "the operand turned about y by k * y (IQ's opTwist)"},
  {"bend", sdf_type::op_bend, sdf_operator_build::unary,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape"},
     {"k", sdf_key_type::number, sdf_key_range::any, sdf_key_field::value,
      true, "radians of turn per unit along x"}},
    "the operand turned about z by k * x (IQ's opCheapBend)"},
  {"repeat", sdf_type::op_repeat, sdf_operator_build::unary,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape, about the origin"},
     {"spacing", sdf_key_type::vec3, sdf_key_range::non_negative,
      sdf_key_field::size, true,
      "distance between copies per axis (0: not repeated along it)"},
     {"limit", sdf_key_type::counts, sdf_key_range::non_negative,
      sdf_key_field::count, false,
      "copies on each side of the origin per axis (absent: without end)"}},
    "copies of the operand on a grid (IQ's opRepetition and "
    "opLimitedRepetition)"},
  {"elongate", sdf_type::op_elongate, sdf_operator_build::unary,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape"},
     {"h", sdf_key_type::vec3, sdf_key_range::non_negative,
      sdf_key_field::size, true, "half the length inserted per axis"}},
    "the operand cut at its centre planes and pulled apart by 2h "
    "(IQ's opElongate)"},
  {"mirror", sdf_type::op_mirror, sdf_operator_build::unary,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape (its + side is kept)"},
     {"axes", sdf_key_type::axes, sdf_key_range::any, sdf_key_field::axes,
      true, "the axes mirrored, e.g. \"x\" or \"xz\""}},
    "the operand's + side mirrored about the planes of the axes (IQ's "
    "opSymX, opSymXZ)"},
  {"expression", sdf_type::math_const, sdf_operator_build::expression,
    {{"expression", sdf_key_type::expression, sdf_key_range::any,
      sdf_key_field::none, false,
      "an infix formula over x, y, z and the operands (or give uri)"},
     {"uri", sdf_key_type::uri, sdf_key_range::any, sdf_key_field::none,
      false, "a .vm file in fidget's format (or give expression)"},
     {"operands", sdf_key_type::operand_map, sdf_key_range::any,
      sdf_key_field::none, false,
      "shapes the formula names (each one used)"},
     {"bounds", sdf_key_type::box, sdf_key_range::any, sdf_key_field::none,
      false, "a box the surface is clipped to (needed when the zero set "
      "is unbounded)"}},
    "the inside of any f(x, y, z) < 0 (no distance needed)"},
  {"displace", sdf_type::math_add, sdf_operator_build::displace,
    {{"operand", sdf_key_type::operand, sdf_key_range::any,
      sdf_key_field::none, true, "the shape"},
     {"expression", sdf_key_type::expression, sdf_key_range::any,
      sdf_key_field::none, true, "the displacement, a formula over x, y, z"}},
    "operand + expression (IQ's opDisplace)"},
};
// clang-format on

// The row named `name`, or nullptr.
inline const sdf_operator* find_sdf_operator(const std::string& name) {
  for (auto& op : sdf_operators)
    if (name == op.name) return &op;
  return nullptr;
}

// The JSON types of sdfunctions: the primitives, then the operators.
inline std::vector<std::string> sdf_json_type_names() {
  auto names = std::vector<std::string>{};
  for (auto i = 0; i < (int)sdf_type::op_union; i++)
    names.push_back(sdf_type_names[i]);
  for (auto& op : sdf_operators) names.push_back(op.name);
  return names;
}

}  // namespace implicit
