// # implicit: fields of simplified tapes
//
// An sdf_field holds a program's tape and an octree over its box whose leaves
// hold the tape simplified to their cell (sdf_simplify.h), and evaluates a
// point with the tape of its leaf. Each leaf also keeps the interval of the
// value over its cell and a Lipschitz bound there, so that a tracer of
// functions that are no distance bounds can step by |f| / L within the cell
// (segment tracing, Galin et al., "Segment Tracing Using Local Lipschitz
// Bounds", Eurographics 2020).
//
// The octree is built lazily: a cell is simplified (from its parent's
// clauses) the first time a point or a walk reaches it, so a render pays
// only for the cells its rays visit, and the first pixel comes after one
// simplification of the whole tape. Whether a cell splits depends on its own
// clauses and depth only, so any thread, in any order, builds the same
// octree, and evaluation gives the same floats; a cell is built once (two
// threads that race for one keep the first result; the second's equals it).
// Past the memory budget new cells stop splitting, which is the one place
// where the order of visits shows (in which cells answer with a constant).
//
// Because a simplified tape equals the whole one inside its cell, the sphere
// tracer's steps over a distance program stay those of the whole field: a
// step may cross into other cells, where the next evaluation uses their
// tapes, and no bound other than the field's own is needed.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "sdf_simplify.h"
#include "sdf_tape.h"

namespace implicit {

// How far an sdf_field subdivides.
struct sdf_field_params {
  int leaf_nodes = 24;  // a cell with at most this many clauses is a leaf
  // Octree levels (-1: about cbrt(nodes) cells per axis); one more where
  // the surface of a function that is no distance bound passes with over
  // 4 x leaf_nodes clauses.
  int    max_depth = -1;
  size_t max_bytes = 0;  // bytes of the cells built; 0: see make_sdf_field
  // Whether a cell whose values keep one sign is split further, when the
  // program is no distance bound: a tracer crosses such a cell whole (no),
  // a bake samples every point of it (yes: short tapes there).
  bool split_one_side = false;
};

// One octree cell: eight children from `children`, or a leaf with its
// simplified clauses, or a leaf with a constant bound: a cell where the
// field keeps one sign and stays at least half the cell's half diagonal from
// zero answers with its least distance (`bound`, the lower end of its range
// outside the surface, the upper end inside). That is no exact value, but it
// is a distance bound of the same sign, no larger in size than the field's,
// so sphere tracing stays safe: its steps stay short of the surface, and no
// hit or normal is ever taken there (every point of the cell is farther from
// the surface than the hit threshold and the normals' finite-difference
// steps). For a program that is no distance bound (sdf_field::distance is
// false) a constant cell only says that the function has no zero there: its
// range excludes 0 and its `bound` has the function's sign, but it is no
// distance. Leaves of such programs keep the Lipschitz bound of their own
// tape over the cell (eval_sdf_lipschitz), +inf where the function may jump.
struct sdf_cell {
  int               children  = invalidid;  // index of the first of 8
  const sdf_clause* clauses   = nullptr;    // leaves: simplified clauses
  int               count     = 0;   // leaves: clauses (0: the constant bound)
  float             bound     = 0;   // leaves without clauses: that bound
  interval          range     = {};  // the values over the cell
  float             lipschitz = flt_inf;  // leaves: bound of |gradient|
  // Leaves of programs that are no distance bounds: the gradient's hull
  // over the cell (entire: unknown), whose projection on a ray bounds df/dt
  // with its sign.
  interval gradient[3] = {entire_interval, entire_interval, entire_interval};
};

// The cells built so far, shared by copies of a field (sdf_field.cpp).
struct sdf_field_cells;

// A program's tape with its simplified versions over an octree of `box`.
// Points outside the box use the whole tape. The leaves' clauses use the
// nodes and maps of the whole tape. Copies share the octree (thread-safe).
struct sdf_field {
  sdf_tape full = {};  // the whole program
  bbox3f   box  = {};  // the root cell (empty: no octree)
  std::shared_ptr<sdf_field_cells> octree = {};  // null: no octree
  int  depth    = 0;     // deepest level a cell may reach (the smallest)
  bool distance = true;  // the program is a distance bound
};

// Build a field of `program` over `box`; programs of at most
// params.leaf_nodes nodes, and unbounded boxes, get no octree. Throws
// io_error as make_sdf_tape().
sdf_field make_sdf_field(const sdf_program& program, const bbox3f& box,
    const sdf_field_params& params = {});

// The leaf cell that holds `p`, or invalidid outside the octree; `box`
// receives the leaf's box. Builds the cells on the way.
int find_sdf_cell(const sdf_field& field, vec3f p);
int find_sdf_cell(const sdf_field& field, vec3f p, bbox3f& box);

// Corner `octant` (bit 0: x, 1: y, 2: z high) of a box split at its centre:
// the box of child `octant` of a cell (find_sdf_tape() computes the same
// midpoints).
bbox3f sdf_octant_box(const bbox3f& box, int octant);

// Cell `cell` (0: the root; children of cells returned here), built if it
// was not. The reference stays valid while the field's octree lives.
const sdf_cell& get_sdf_cell(const sdf_field& field, int cell);

// Value at a local point with the tape of a leaf (its bound if constant;
// no leaf, outside the octree: the whole tape).
inline float eval_sdf_leaf(
    const sdf_field& field, const sdf_cell* leaf, vec3f p) {
  if (!leaf) return eval_sdf(field.full, p);
  if (leaf->count == 0) return leaf->bound;
  return eval_sdf(field.full, leaf->clauses, leaf->clauses + leaf->count, p);
}
// Value at a local point with the tape of cell `cell` (a leaf from
// find_sdf_cell, or invalidid for the whole tape). Allocates nothing.
inline float eval_sdf_cell(const sdf_field& field, int cell, vec3f p) {
  return eval_sdf_leaf(
      field, cell < 0 ? nullptr : &get_sdf_cell(field, cell), p);
}

// Distance bound at a local point: exact near the surface, see sdf_cell.
inline float eval_sdf(const sdf_field& field, vec3f p) {
  return eval_sdf_cell(field, find_sdf_cell(field, p), p);
}

// The leaf that the last point of a walk fell in (a march along a ray moves
// a little at a time), and its ancestors: the next point inside the leaf's
// box skips the descent, and one inside an ancestor's box descends from
// there, not from the root. Boxes are half open, [min, max), as
// find_sdf_cell splits them, so the leaf is the one it would find: a point
// in a cell's half-open box lies on its side of every split above it.
// With a direction, a point on a face counts on the side the direction
// points into along that axis: (min, max] where it is negative. A ray's
// point on the face it leaves a cell by then lies in the cell it enters.
inline bool inside_towards(const bbox3f& b, vec3f p, vec3f direction) {
  for (auto a = 0; a < 3; a++) {
    auto x = at(p, a), lo = at(b.min, a), hi = at(b.max, a);
    if (at(direction, a) < 0 ? !(lo < x && x <= hi) : !(lo <= x && x < hi))
      return false;
  }
  return true;
}
inline bool inside_half_open(const bbox3f& b, vec3f p) {
  return inside_towards(b, p, {});
}
inline constexpr int sdf_cursor_depth = 16;  // ancestors kept, from the root
struct sdf_field_cursor {
  int             cell = invalidid;  // the leaf
  const sdf_cell* leaf = nullptr;    // its cell (null outside the octree)
  bbox3f          box  = {};         // its box
  int    count = 0;  // cells kept: path[0] the root, down the leaf's path
  int    path[sdf_cursor_depth]  = {};
  bbox3f boxes[sdf_cursor_depth] = {};
};
// The leaf holding p (invalidid outside the field), from the cursor's path;
// updates the cursor. A point on a face between cells lies in the one
// `direction` points into (inside_towards; zero: the upper one).
int find_sdf_cell(const sdf_field& field, vec3f p, sdf_field_cursor& cursor,
    vec3f direction = {});
inline float eval_sdf(
    const sdf_field& field, vec3f p, sdf_field_cursor& cursor) {
  if (!(cursor.cell >= 0 && inside_half_open(cursor.box, p)))
    find_sdf_cell(field, p, cursor);
  return eval_sdf_leaf(field, cursor.leaf, p);
}

// Interval of the values over `box` (inside the cell) with the tape of
// cell `cell`; a constant cell gives its range.
interval eval_sdf_cell_interval(
    const sdf_field& field, int cell, const bbox3f& box);

// Unit gradient at a local point; each finite-difference sample uses the
// tape of its own cell, so it is the gradient of the whole field.
vec3f eval_sdf_gradient(const sdf_field& field, vec3f p, float step);

// Build every cell of the octree (tests, benchmarks: lazy fields build
// what they visit).
void build_sdf_field(const sdf_field& field);

// Bytes of a whole field, its cells built so far included.
size_t sdf_field_bytes(const sdf_field& field);
// Cells built so far (0 without an octree).
size_t sdf_field_cells_built(const sdf_field& field);

}  // namespace implicit
