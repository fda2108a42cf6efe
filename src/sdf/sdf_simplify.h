// # implicit: per-cell simplification of SDF tapes
//
// A model of many operands (a blob of smooth-unioned spheres, a plate with
// hundreds of holes) or a long expression changes, in any small region, only
// because of a few of its clauses. simplify_sdf() restricts an SSA tape to a
// box: it bounds every clause over the box by interval arithmetic, then drops
// what cannot change the root's value there, so the simplified tape equals
// the whole one at every point of the box:
// - the operand of a min or max (hard or smooth CSG operator, or math
//   clause) that interval arithmetic decides, with the caps and floors of
//   Lipschitz pruning (Barbier et al., "Lipschitz Pruning", Eurographics
//   2025), which also drop operands that cannot reach the root through the
//   operators above them (the proofs are in sdf_simplify.cpp);
// - the branch of an `and` or `or` whose condition is decided;
// - clauses whose value is one number over the box become constants;
// - clauses nothing reads any more.
// This is the tape simplification of Keeter ("Massively Parallel Rendering of
// Complex Closed-Form Implicit Surfaces", SIGGRAPH 2020) and of fidget
// (`simplify` with the choices an interval evaluation records).
#pragma once

#include <vector>

#include "sdf_tape.h"

namespace implicit {

// Scratch space of simplify_sdf, one slot per clause, reused across calls so
// that simplifying many cells allocates once.
struct sdf_simplify_state {
  std::vector<interval>             values = {};  // each clause's interval
  std::vector<sdf_box_point>        points = {};  // each point clause's box
  std::vector<sdf_smooth_intervals> groups = {};  // each group clause's
  std::vector<int>                  chain  = {};  // the adds of one group
  std::vector<float>                caps   = {};
  std::vector<float>                floors = {};
  std::vector<int>                  pass   = {};  // the clause a clause becomes
  std::vector<int>                  index  = {};  // position in the output
  std::vector<char>                 state  = {};  // unreached, kept or folded
  // Scratch of the octree's builds (sdf_field.cpp): a cell's clauses, and
  // a leaf's in registers, before they are copied at their size.
  std::vector<sdf_ssa>    output    = {};
  std::vector<sdf_clause> registers = {};
};

// Whether a range lies `far` or farther from 0 (on either side).
inline bool is_far(interval range, float far) {
  return range.lo >= far || range.hi <= -far;
}

// The SSA clauses `ssa` (over the nodes and maps of `pool`) restricted to
// `box`, appended to `simplified`: equal to `ssa` at every point of the box
// (up to float rounding). Returns the interval of the root over the box.
// When that interval is_far() from 0, nothing is appended: a
// caller that keeps only a bound there skips the two passes that drop.
interval simplify_sdf(const sdf_tape& pool, const std::vector<sdf_ssa>& ssa,
    const bbox3f& box, sdf_simplify_state& state,
    std::vector<sdf_ssa>& simplified, float far = flt_inf);

// A tape restricted to `box`: its nodes and maps with the simplified clauses
// (for tests and single queries; fields keep one pool for all their cells).
sdf_tape simplify_sdf(const sdf_tape& tape, const bbox3f& box);

}  // namespace implicit
