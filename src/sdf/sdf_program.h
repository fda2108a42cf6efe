// # implicit: SDF programs
//
// An analytic SDF is a small expression tree stored as a flat node array:
// primitives are leaves, operators reference their operands by index. The
// tree is plain data; evaluation is a `switch` on the node type, never a
// virtual or std::function call. Every program knows the bounding box of its
// zero set and its Lipschitz bound, so the tracer can march it safely and
// only where it can be hit.
#pragma once

#include <string>
#include <vector>

#include "../math/math.h"
#include "sdf_primitive_table.h"

namespace implicit {

// -----------------------------------------------------------------------------
// NODES
// -----------------------------------------------------------------------------

// Node types: primitives first (the rows of sdf_primitive_table.h), then the
// CSG operators, the domain operators and the math clauses. Names in
// sdf_type_names (JSON and UI names; math clauses have their `.vm` opcode,
// so "round" names both the CSG rounding and, later, the math clause: look
// math names up in sdf_math_names).
// clang-format off
#define IMPLICIT_SDF_ENUM(id, name) id,
#define IMPLICIT_SDF_MATH_ENUM(id, name, operands) id,
enum class sdf_type {
  IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_ENUM)
  IMPLICIT_SDF_OPERATORS(IMPLICIT_SDF_ENUM)
  IMPLICIT_SDF_WARPS(IMPLICIT_SDF_ENUM)
  IMPLICIT_SDF_MATH(IMPLICIT_SDF_MATH_ENUM)
};
#undef IMPLICIT_SDF_MATH_ENUM
#undef IMPLICIT_SDF_ENUM

#define IMPLICIT_SDF_NAME(id, name) name,
#define IMPLICIT_SDF_MATH_NAME(id, name, operands) name,
inline const std::vector<std::string> sdf_type_names = {
  IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_NAME)
  IMPLICIT_SDF_OPERATORS(IMPLICIT_SDF_NAME)
  IMPLICIT_SDF_WARPS(IMPLICIT_SDF_NAME)
  IMPLICIT_SDF_MATH(IMPLICIT_SDF_MATH_NAME)
};
// The `.vm` opcodes of the math clauses, in enum order from math_const.
inline const std::vector<std::string> sdf_math_names = {
  IMPLICIT_SDF_MATH(IMPLICIT_SDF_MATH_NAME)
};
#undef IMPLICIT_SDF_MATH_NAME
#undef IMPLICIT_SDF_NAME
// clang-format on

// True for leaves of the seed's kind (shapes), false for the rest.
inline bool is_primitive(sdf_type type) { return type < sdf_type::op_union; }
// True for the domain operators (twist .. mirror).
inline bool is_warp(sdf_type type) {
  return type >= sdf_type::op_twist && type <= sdf_type::op_mirror;
}
// True for the math clauses (const .. or).
inline bool is_math(sdf_type type) { return type >= sdf_type::math_const; }

// One node. Parameters are named by meaning; each type reads only its own:
// primitives those of their sdf_params_<id> (sdf_primitives.h); smooth ops
// blend; round radius (added thickness); onion thickness (half shell);
// transform frame (child_from_parent) and operand left. Subtraction removes
// `right` from `left`.
//
// Domain operators evaluate their operand `left` at q(p), p the point in the
// operator's space (after Inigo Quilez, iquilezles.org/articles/
// distfunctions):
//   twist     rotation about y by value * p.y:
//             q = (c p.x - s p.z, p.y, s p.x + c p.z), c, s = cos, sin of it
//   bend      rotation about z by value * p.x:
//             q = (c p.x - s p.y, s p.x + c p.y, p.z)
//   repeat    per axis a with size[a] > 0: q[a] = p[a] - size[a] * n, with
//             n = round(p[a] / size[a]) clamped to [-count[a], count[a]]
//             when count[a] >= 0 (limited repetition), unclamped when
//             count[a] < 0; axes with size[a] == 0 are not repeated
//   elongate  q = p - clamp(p, -size, size)
//   mirror    q[a] = |p[a]| for each axis a whose bit is set in `axes`
// Displacement is no node of its own: math_add of the operand and the
// displacement (both in the same space).
//
// Math clauses (operands `left`, then `right`; NaN follows IEEE unless said):
//   const value; var-x, var-y, var-z the point's coordinates in the node's
//   space; neg abs square sqrt exp ln sin cos tan asin acos atan floor ceil of
//   left; round of left to the nearest integer, halves away from zero
//   (std::round); not: 1 if left == 0 else 0; add sub mul div min max of
//   left and right (min and max give NaN if either is NaN); atan2(left,
//   right) = atan2(y = left, x = right); mod: the remainder of left / right
//   in [0, |right|) (fidget's rem_euclid); compare: -1, 0 or 1 as left <, ==,
//   > right, NaN if either is NaN; and: left if left == 0 else right; or:
//   left if left != 0 else right.
// A NaN value counts as outside (positive) wherever a sign is taken; an
// interval over a region where the value may be NaN is [-inf, +inf].
struct sdf_node {
  sdf_type type      = sdf_type::sphere;
  vec3f    size      = {0, 0, 0};  // also: repeat period, elongate extent
  float    radius    = 0;
  float    radius2   = 0;
  float    height    = 0;
  float    thickness = 0;
  float    blend     = 0;
  float    value     = 0;             // const; twist, bend: radians per unit
  vec3i    count     = {-1, -1, -1};  // repeat: copies each side (< 0: all)
  int      axes      = 0;             // mirror: bit 0 x, bit 1 y, bit 2 z
  int      left      = invalidid;
  int      right     = invalidid;
  int      frame     = invalidid;  // index in sdf_program::frames
  int      origin    = invalidid;  // pruned copies: the node it came from
};

// A flat expression graph. Operands come before the nodes that use them; the
// root is the last node. CSG models are trees; math clauses may share an
// operand between several users (a `.vm` file is such a graph), always within
// one space (no transform or domain operator lies between a shared node and
// only some of its users). `frames` hold child_from_parent maps of transforms
// and `frame_scales` the matching distance factors (1 / largest stretch).
struct sdf_program {
  std::vector<sdf_node> nodes        = {};
  std::vector<frame3f>  frames       = {};
  std::vector<float>    frame_scales = {};
};

// -----------------------------------------------------------------------------
// BUILDING
// -----------------------------------------------------------------------------

// Append a node and return its index (the new root).
int add_node(sdf_program& program, const sdf_node& node);
// Append a transform node over `operand`, `child_from_parent` mapping the
// parent's points into the operand's space.
int add_transform(
    sdf_program& program, int operand, const frame3f& child_from_parent);
// Combine the operand roots `operands` (at least one) with the binary
// operator `op` (its `left` and `right` are set here) and return the root.
// Smooth unions and smooth intersections pair neighbours level by level into
// a balanced tree, ((1 2) (3 4)) ((5 6) 7), the same as folding left for 2
// and 3 operands: a smooth fold depends on every operand before the nearest
// ones, so a left fold of a long list could not be pruned in space, while
// the balanced tree of a spatially ordered list leaves each region a few
// operands (a smooth union's tree is one group below, whatever its shape).
// The other operators fold left, ((1 2) 3) 4, which for unions and
// intersections is the same function and makes subtraction remove 2.. from 1.
int fold_sdf_operands(
    sdf_program& program, const std::vector<int>& operands, sdf_node op);
// Smooth union groups: a smooth union whose operand is a smooth union of
// the same blend, read by it alone, takes that operand's operands as its
// own, so a list (however fold_sdf_operands paired it) or a nest of one
// blend is one n-ary smooth union. Its value is the smooth minimum of its
// sdf_smooth_group_size smallest operand values folded in increasing order
// (sdf_tape_eval.h): the same for any order or grouping of the operands, a
// distance bound, and exactly the operands below min(hi) + blend matter
// over a box (sdf_simplify.cpp). Returns, per node, whether its user's
// group absorbs it.
std::vector<char> find_smooth_groups(const sdf_program& program);
// The operands of the group rooted at `root` (a smooth union that is not
// absorbed), in list order; explicit stack.
void                 smooth_group_operands(const sdf_program& program,
                    const std::vector<char>& absorbed, int root, std::vector<int>& operands);
inline constexpr int sdf_smooth_group_size = 8;
// Append the nodes of `other` (its root becomes an operand); returns its root.
int append_program(sdf_program& program, const sdf_program& other);
// A one-node program.
sdf_program make_primitive_program(const sdf_node& node);
// Index of the root node.
inline int root_node(const sdf_program& program) {
  return (int)program.nodes.size() - 1;
}

// Most nodes in one program: node indices are ints, and a loader refuses a
// larger model (with its file and element) before allocating it.
inline constexpr int sdf_max_nodes = 1 << 26;

// Number of operands of a node: 0 for primitives and for math clauses
// without any (const, var-x/y/z), then 1 or 2 (`left`, then `right`).
int sdf_operand_count(sdf_type type);

// -----------------------------------------------------------------------------
// EVALUATION (sdf_tape.h compiles and evaluates whole programs)
// -----------------------------------------------------------------------------

// (eval_primitive, the distance of one primitive node at a local point, is
// in sdf_primitives.h: inline, for the tapes' loops.)
// Analytic gradient of one primitive where it is cheap and exact (sphere,
// plane, box, torus; unit length); false for the others.
bool eval_primitive_gradient(const sdf_node& node, vec3f p, vec3f& g);

// Bounding box of the zero set of one primitive, in its local space.
bbox3f primitive_bounds(const sdf_node& node);
// Lipschitz factor of one primitive (1 for exact distances).
float primitive_lipschitz(const sdf_node& node);
// JSON parameters of a primitive (none for operators).
sdf_param_list primitive_params(sdf_type type);
// Checks across the parameters of a primitive whose parameters are each in
// range (no problem for operators).
sdf_param_problem check_primitive(const sdf_node& node);

// Bounding box of the zero set, in local space. Unbounded axes are infinite.
bbox3f sdf_bounds(const sdf_program& program);
// The box of every node's zero set (empty for smooth unions absorbed into
// a group: its root's box holds them); the last is sdf_bounds().
std::vector<bbox3f> sdf_node_bounds(const sdf_program& program);
// Lipschitz bound of the program (1 for exact distances): the largest of
// its primitives' factors when the program is a distance bound (primitives,
// CSG operators, transforms, elongate and mirror, which are 1-Lipschitz
// maps), +inf otherwise (math clauses, twist, bend, repeat: their bound is
// local, see sdf_field.h).
float sdf_lipschitz(const sdf_program& program);

// Closed-form intersection of one primitive node, when one exists (sphere,
// box, plane). Returns false when the node has none; otherwise `hit` tells
// whether the ray hits in [tmin, tmax] and `t` is the first hit.
bool intersect_sdf_exact(
    const sdf_node& node, const ray3f& ray, bool& hit, float& t);
// Whether intersect_sdf_exact() applies to this one-node program.
bool has_exact_intersection(const sdf_program& program);

}  // namespace implicit
