// # implicit: spatial pruning of SDF programs
//
// A model of many operands (a blob of smooth-unioned spheres, a plate with
// hundreds of holes) changes, in any small region, only because of the few
// operands near it. prune_sdf() restricts a program to a box: it bounds the
// value of every node over the box (the value at the box centre plus or minus
// the node's Lipschitz factor times the half diagonal, propagated through the
// operators), then drops every operand that cannot change the root's value
// there, so the pruned program equals the whole one at every point of the
// box. An sdf_field stores such programs in the leaves of an octree over the
// object's box, built top-down (each cell prunes its parent's program, so the
// total work is about the node count times the depth), and evaluates a point
// with the program of its leaf. Anchors: Lipschitz pruning (Barbier et al.,
// "Lipschitz Pruning", Eurographics 2025: per-cell pruned trees for hard and
// smooth operators) and tape simplification by interval arithmetic (Keeter,
// "Massively Parallel Rendering of Complex Closed-Form Implicit Surfaces",
// SIGGRAPH 2020).
//
// Because a pruned program equals the whole field inside its cell, the sphere
// tracer's steps stay those of the whole field: a step may cross into other
// cells, where the next evaluation uses their programs, and no bound other
// than the field's own is needed.
#pragma once

#include <cstddef>
#include <vector>

#include "sdf_program.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PRUNING
// -----------------------------------------------------------------------------

// The program restricted to `box`: equal to `program` at every point of the
// box (up to float rounding), without the operands that cannot change its
// value there, and with chains of transforms merged into one.
sdf_program prune_sdf(const sdf_program& program, const bbox3f& box);
// As above; `range` receives bounds of the program's values over the box.
sdf_program prune_sdf(
    const sdf_program& program, const bbox3f& box, vec2f& range);

// The operands of the hard union at the root of `program`, through
// transforms and nested hard unions, each as its own program in the
// program's space (the transforms above it merged into one). Operands with
// unbounded or empty boxes stay together as one more part, the union of
// them. A program whose root is no hard union is its own only part.
std::vector<sdf_program> split_sdf_union(const sdf_program& program);

// -----------------------------------------------------------------------------
// FIELDS
// -----------------------------------------------------------------------------

// How far an sdf_field subdivides.
struct sdf_field_params {
  int    leaf_nodes = 24;  // a cell with at most this many nodes is a leaf
  int    max_depth  = -1;  // octree levels; -1: about cbrt(nodes) cells/axis
  size_t max_bytes  = 0;   // bytes of all leaf steps; 0: see make_sdf_field
};

// One octree cell: eight children from `children`, or a leaf with the steps
// of its pruned program, or a leaf with a constant bound: a cell where the
// field keeps one sign and stays at least half the cell's half diagonal from
// zero answers with its least distance (`bound`, the lower end of its range
// outside the surface, the upper end inside). That is no exact value, but it is
// a distance bound of the same sign, no larger in size than the field's, so
// sphere tracing stays safe: its steps stay short of the surface, and no hit or
// normal is ever taken there (every point of the cell is farther from the
// surface than the hit threshold and the normals' finite-difference steps).
struct sdf_cell {
  int   children = invalidid;  // index of the first of 8 in sdf_field::cells
  int   begin    = invalidid;  // leaves: first step in sdf_field::instrs
  int   count    = 0;          // leaves: steps (0: the constant bound)
  float bound    = 0;          // leaves without steps: the constant bound
};

// A program with its pruned versions over an octree of `box`. Points outside
// the box use the whole program. The leaves' steps index the nodes and maps
// of the whole program's tape. Plain data: copies and moves are safe.
struct sdf_field {
  sdf_tape               full   = {};  // the whole program
  bbox3f                 box    = {};  // the root cell (empty: no octree)
  std::vector<sdf_cell>  cells  = {};  // cells[0] is the root
  std::vector<sdf_instr> instrs = {};  // leaf steps, one range per leaf
  int                    depth  = 0;   // deepest level built
};

// Build a field of `program` over `box`; programs of at most
// params.leaf_nodes nodes, and unbounded boxes, get no octree. Throws
// io_error as make_sdf_tape().
sdf_field make_sdf_field(const sdf_program& program, const bbox3f& box,
    const sdf_field_params& params = {});

// The leaf cell that holds `p`, or invalidid outside the octree.
int find_sdf_cell(const sdf_field& field, vec3f p);

// Distance bound at a local point: exact near the surface, see sdf_cell
// (allocates nothing).
inline float eval_sdf(const sdf_field& field, vec3f p) {
  auto cell = find_sdf_cell(field, p);
  if (cell < 0) return eval_sdf(field.full, p);
  auto& leaf = field.cells[cell];
  if (leaf.count == 0) return leaf.bound;
  auto begin = field.instrs.data() + leaf.begin;
  return eval_sdf(field.full, begin, begin + leaf.count, p);
}

// Unit gradient at a local point; each finite-difference sample uses the
// tape of its own cell, so it is the gradient of the whole field.
vec3f eval_sdf_gradient(const sdf_field& field, vec3f p, float step);

// Bytes of a tape and of a whole field.
size_t sdf_tape_bytes(const sdf_tape& tape);
size_t sdf_field_bytes(const sdf_field& field);

}  // namespace implicit
