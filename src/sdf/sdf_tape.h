// # implicit: SDF tapes
//
// A program (sdf_program.h: primitives, CSG operators, domain operators and
// math clauses, as a flat DAG) is compiled once into a tape: a flat list of
// clauses {opcode, output, inputs, parameter}, run by one loop with a
// `switch` per clause, as libfive's (eval/tape.hpp) and fidget's
// (vm/mod.rs) evaluators run theirs. The tape comes in two forms:
//
// - SSA (`sdf_tape::ssa`): clause i writes value i; its inputs name earlier
//   clauses. Shared subexpressions are one clause, constants are folded, and
//   the transforms between two point clauses are composed into one affine
//   map (in `frames`). Per-cell simplification (sdf_simplify.h) reads and
//   writes this form.
// - Registers (`sdf_tape::clauses`): the same clauses with their values in
//   a fixed file of 256 scalar, 64 point and 16 group registers (the
//   accumulators of n-ary smooth unions), assigned by a reverse
//   linear scan (fidget's compiler/alloc.rs: walking from the root, a value
//   takes a register at its last use and frees it at its definition), so a
//   model of any size evaluates with a few kilobytes of stack. A program that
//   needs more live values at once is refused with an io_error. A constant
//   operand of add, sub, mul, div, min or max becomes the clause's parameter
//   (an immediate, as fidget's AddRegImm), with no clause or register.
//
// Points are values too: the input clause writes the evaluation point, a map
// clause applies an affine map, the domain operators (twist .. mirror) warp a
// point into a new one, and var-x/y/z read a point's coordinate. Primitives
// read a point register through their own composed map (nodes[param].frame),
// so a CSG model needs one clause per primitive and per operator.
//
// The evaluators (points, batches of points, intervals over boxes, value and
// gradient, interval gradients) are one loop templated on the value type
// (sdf_tape_eval.h); none throws or allocates.
#pragma once

#include <cstdint>
#include <cstring>
#include <vector>

#include "../math/dual.h"
#include "../math/interval.h"
#include "sdf_program.h"

namespace implicit {

// -----------------------------------------------------------------------------
// CLAUSES
// -----------------------------------------------------------------------------

// Clause opcodes: point clauses, then distance clauses (primitives and CSG
// operators, whose meaning is that of the sdf_type of the same name), then
// the math clauses of IMPLICIT_SDF_MATH (sdf_program.h gives each one's
// value). The parameter of each:
//   input                          none: writes the evaluation point
//   map                            index in sdf_tape::frames
//   twist bend repeat elongate mirror shape
//                                  index in sdf_tape::nodes
//   scale (a * s) smooth_* (blend) round (radius) onion (thickness)
//   smooth_open smooth_add smooth_close
//                                  a smooth union group (sdf_program.h) of
//                                  3 operands or more: open starts an
//                                  accumulator, each add puts an operand
//                                  (b) into it (a), close folds it (blend)
//   math_const (value)             the float's bits (sdf_param_float)
//   math_add_k .. math_max_k       the constant operand's bits (b)
// clang-format off
#define IMPLICIT_SDF_OP_ENUM(id) id,
#define IMPLICIT_SDF_OP_MATH_ENUM(id, name, operands) id,
#define IMPLICIT_SDF_OP_IMMEDIATE_ENUM(id) id##_k,
// Register-tape forms of binary math clauses whose second operand is a
// constant (`math_add_k`: a + the parameter's float), as fidget's
// AddRegImm: the tape spends neither a clause nor a register on the
// constant. Only allocate_sdf_registers writes them; SSA never holds them.
#define IMPLICIT_SDF_IMMEDIATE_OPS(X) \
  X(math_add) X(math_sub) X(math_mul) X(math_div) X(math_min) X(math_max)
#define IMPLICIT_SDF_POINT_OPS(X) \
  X(input) X(map) X(twist) X(bend) X(repeat) X(elongate) X(mirror)
#define IMPLICIT_SDF_DISTANCE_OPS(X)                                         \
  X(shape) X(scale) X(csg_union) X(csg_intersection) X(csg_subtraction)    \
  X(csg_smooth_union) X(csg_smooth_intersection) X(csg_smooth_subtraction) \
  X(csg_round) X(csg_onion) X(smooth_open) X(smooth_add) X(smooth_close)
enum class sdf_op : uint8_t {
  IMPLICIT_SDF_POINT_OPS(IMPLICIT_SDF_OP_ENUM)
  IMPLICIT_SDF_DISTANCE_OPS(IMPLICIT_SDF_OP_ENUM)
  IMPLICIT_SDF_MATH(IMPLICIT_SDF_OP_MATH_ENUM)
  IMPLICIT_SDF_IMMEDIATE_OPS(IMPLICIT_SDF_OP_IMMEDIATE_ENUM)
};
#undef IMPLICIT_SDF_OP_IMMEDIATE_ENUM
#undef IMPLICIT_SDF_OP_MATH_ENUM
#undef IMPLICIT_SDF_OP_ENUM
// clang-format on

// `case sdf_op::id:` for each point clause, each distance clause and each
// math clause.
#define IMPLICIT_SDF_OP_CASE(id) case sdf_op::id:
#define IMPLICIT_SDF_OP_MATH_CASE(id, name, operands) case sdf_op::id:
#define IMPLICIT_SDF_POINT_CASES IMPLICIT_SDF_POINT_OPS(IMPLICIT_SDF_OP_CASE)
#define IMPLICIT_SDF_DISTANCE_CASES \
  IMPLICIT_SDF_DISTANCE_OPS(IMPLICIT_SDF_OP_CASE)
#define IMPLICIT_SDF_MATH_OP_CASES IMPLICIT_SDF_MATH(IMPLICIT_SDF_OP_MATH_CASE)
#define IMPLICIT_SDF_OP_IMMEDIATE_CASE(id) case sdf_op::id##_k:
#define IMPLICIT_SDF_IMMEDIATE_CASES \
  IMPLICIT_SDF_IMMEDIATE_OPS(IMPLICIT_SDF_OP_IMMEDIATE_CASE)

// Whether a clause writes a point (else a scalar or a group).
inline bool is_point_op(sdf_op op) { return op <= sdf_op::mirror; }
// Whether a clause writes a smooth union group's accumulator.
inline bool is_group_op(sdf_op op) {
  return op == sdf_op::smooth_open || op == sdf_op::smooth_add;
}
// Number of inputs of a clause (points included).
int sdf_op_inputs(sdf_op op);
// Whether input k (0 or 1) of a clause is a point.
inline bool is_point_input(sdf_op op, int k) {
  return k == 0 && (op <= sdf_op::shape || op == sdf_op::math_x ||
                       op == sdf_op::math_y || op == sdf_op::math_z);
}

// A clause of the register tape: 8 bytes.
struct sdf_clause {
  sdf_op   op    = sdf_op::math_const;
  uint8_t  out   = 0;  // register written (point or scalar file)
  uint8_t  a     = 0;  // registers read
  uint8_t  b     = 0;
  uint32_t param = 0;
};

// A clause of the SSA tape: its output is its index in the list.
struct sdf_ssa {
  sdf_op   op    = sdf_op::math_const;
  int      a     = invalidid;  // earlier clauses read
  int      b     = invalidid;
  uint32_t param = 0;
};

// A float parameter stored in a clause, and back.
inline uint32_t sdf_float_param(float value) {
  auto bits = uint32_t{0};
  std::memcpy(&bits, &value, sizeof(bits));
  return bits;
}
inline float sdf_param_float(uint32_t bits) {
  auto value = 0.0f;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

// A box of points for interval evaluation: its coordinates' intervals, and
// the ball (centre, radius) about it that primitives are bounded over.
struct sdf_box_point {
  interval x = {}, y = {}, z = {};
  vec3f    centre = {};
  float    radius = 0;
};

// The accumulator of a smooth union group (sdf_tape_eval.h adds to it and
// folds it): the sdf_smooth_group_size smallest values so far, sorted, and
// whether one was NaN. No initializers: smooth_open sets them, so a register
// file of accumulators costs nothing to declare.
struct sdf_smooth_floats {
  float v[sdf_smooth_group_size];
  int   count;
  bool  nan;
};
// Over a box: the lower and upper ends, whether one may be NaN, and the
// hull of the gradients of the operands that may matter (dual intervals).
struct sdf_smooth_intervals {
  sdf_smooth_floats lo, hi;
  bool              entire;
  float             least_hi;
  interval          d[3];
};

// -----------------------------------------------------------------------------
// TAPES
// -----------------------------------------------------------------------------

// Size of the register files. Register indices are bytes (fidget also
// stops at 255); points are few (one per live domain operator or map).
inline constexpr int sdf_max_registers = 256;
inline constexpr int sdf_max_points    = 64;
inline constexpr int sdf_max_groups    = 16;  // accumulators open at once

// A compiled program. Clause ranges of other tapes (the per-cell tapes of an
// sdf_field) are evaluated with this tape's nodes and maps: it is their pool.
struct sdf_tape {
  std::vector<sdf_clause> clauses   = {};  // register form, root last
  std::vector<sdf_ssa>    ssa       = {};  // SSA form, root last
  std::vector<sdf_node>   nodes     = {};  // primitives and domain operators
  std::vector<frame3f>    frames    = {};  // composed maps of point spaces
  std::vector<float>      stretches = {};  // bound of each map's stretch
  float lipschitz = 1;     // global bound (sdf_lipschitz; +inf if none)
  bool  jumps     = true;  // a clause may jump (is_jump_op); false: none
};

// Clauses whose value may jump: a repeat at its copies' borders, floor,
// ceil, round, mod and compare at their steps.
inline bool is_jump_op(sdf_op op) {
  return op == sdf_op::repeat || op == sdf_op::math_floor ||
         op == sdf_op::math_ceil || op == sdf_op::math_round ||
         op == sdf_op::math_mod || op == sdf_op::math_compare;
}

// Compile a program. A primitive's node keeps in `frame` its composed map
// (invalidid for none) and in `origin` its index in the program. Throws
// io_error if an operand does not come before its user, if a node is shared
// by users in different spaces, or if the program needs more than the
// register files hold.
sdf_tape make_sdf_tape(const sdf_program& program);

// Assign registers to SSA clauses (root last); appends to `clauses`. Returns
// false, appending nothing, if the files are too small.
bool allocate_sdf_registers(
    const std::vector<sdf_ssa>& ssa, std::vector<sdf_clause>& clauses);

// A math clause of one or two operands on floats (constant folding).
float eval_sdf_math(sdf_op op, float a, float b);

// Whether the tape is one primitive evaluated in the input's own space.
bool is_single_shape(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, sdf_node& shape);

// -----------------------------------------------------------------------------
// EVALUATION
// -----------------------------------------------------------------------------

// Value of a tape at a point. Allocates nothing.
float eval_sdf(const sdf_tape& tape, vec3f p);
// Value of the clauses [begin, end) over the nodes and maps of `pool`.
float eval_sdf(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p);
// Values at `count` points, many points per pass over the clauses (the
// batched evaluator of meshing, baking and Python).
void eval_sdf(
    const sdf_tape& tape, const vec3f* points, float* values, size_t count);
void eval_sdf(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const vec3f* points, float* values, size_t count);

// Value and exact gradient at a point (forward-mode derivatives, dual.h):
// primitives give their analytic gradient where sdf_primitives has one and
// tetrahedral differences of the primitive alone, in its own space,
// otherwise; the maps and domain operators above them chain it.
dual<float> eval_sdf_dual(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p);
dual<float> eval_sdf_dual(const sdf_tape& tape, vec3f p);
// Value and derivative along `direction` (d/dt at p + t direction) at a
// point: the gradient's dot product with it, for a third of the work.
dual<float, 1> eval_sdf_slope(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p, vec3f direction);
// Values and gradients at `count` points.
void eval_sdf_gradients(const sdf_tape& tape, const vec3f* points,
    float* values, vec3f* gradients, size_t count);

// Interval of the value over a box (sound: every value at a point of the
// box lies in it; entire where the value may be NaN). Primitives are bounded
// by their value at the centre of the box's ball plus or minus their
// Lipschitz factor times its radius.
interval eval_sdf_interval(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box);
interval eval_sdf_interval(const sdf_tape& tape, const bbox3f& box);
// Intervals of the value and of its partial derivatives over a box.
dual<interval> eval_sdf_dual(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box);
dual<interval> eval_sdf_dual(const sdf_tape& tape, const bbox3f& box);
// Intervals of the value and of its derivative along `direction` over a box
// (a box around a piece of a ray: a bound of df/dt along it, as tight as the
// partials' hull projected on the direction or tighter, for a third of the
// work).
dual<interval, 1> eval_sdf_slope(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box, vec3f direction);
// A Lipschitz bound over a box: the largest gradient length there, +inf
// where a derivative is unbounded (a jump of floor, round, mod or repeat,
// sqrt or ln at 0, a value that may be NaN).
float eval_sdf_lipschitz(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box);
float eval_sdf_lipschitz(const sdf_tape& tape, const bbox3f& box);

// Where the segment from p0 to p1 first reaches a jump of the clauses
// [begin, end): the border between two copies of a repeat, an integer for
// floor and ceil, half way between two for round, a multiple of the divisor
// for mod, 0 for compare's difference. The fraction of the way in (0, 1),
// estimated as if each jumping clause's inputs moved linearly between their
// values at the ends (exact for a repeat or floor of a coordinate under
// frames only); NaN when no jumping clause changes branch between the ends.
// A march splits a piece of a ray there, so that its parts have a slope
// bound and a tight range (a piece across a jump has neither).
float find_sdf_jump(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p0, vec3f p1);

// Unit gradient of a tape: analytic for a single simple primitive,
// otherwise tetrahedral central differences with step `step` (the normals of
// distance programs, unchanged from the stack tape).
vec3f eval_sdf_gradient(const sdf_tape& tape, vec3f p, float step);

// Bytes of a tape.
size_t sdf_tape_bytes(const sdf_tape& tape);

}  // namespace implicit
