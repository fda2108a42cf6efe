// # implicit: per-cell simplification of SDF tapes (implementation)
//
// ## Why pruning keeps the value
//
// Over the box, every node n has an interval [lo_n, hi_n] holding its values
// (bottom-up: primitives from the centre value and their Lipschitz bound,
// operators from their operands' intervals). Top-down, every kept node gets a
// "cap" and a "floor": the root's value does not change if n's value is
// replaced by any g with g = n where floor < n < cap, g >= cap where n >= cap
// and g <= floor where n <= floor (the root has cap = +inf, floor = -inf).
// An operand whose whole interval lies at or above its cap (or at or below
// its floor) can thus be replaced by +inf (-inf), which removes it from its
// operator. The rules, for an operator n with operands a, b (the same with a
// and b swapped):
//
// - min(a, b): a gets cap min(cap_n, hi_b), floor floor_n. Where a >= hi_b,
//   a >= b, so min(g, b) = b = min(a, b) for any g >= hi_b. Where
//   a >= cap_n, min(a, b) and min(g, b) are both b if b < cap_n, and both
//   >= cap_n otherwise: n keeps its cap. Where a <= floor_n, both minima
//   are <= floor_n. So a with lo_a >= min(cap_n, hi_b) is dropped and n
//   becomes b (a hard union drops an operand whose lower bound exceeds the
//   upper bound of the other: blend 0 in the smooth rule below).
// - max(a, b): the mirror image: a gets floor max(floor_n, lo_b), cap cap_n;
//   a with hi_a <= max(floor_n, lo_b) is dropped.
// - max(a, -b) (subtraction): a gets floor max(floor_n, -hi_b) (where
//   a <= -hi_b <= -b the maximum is -b) and cap cap_n; -b gets floor
//   max(floor_n, lo_a), so b gets cap -max(floor_n, lo_a) and floor -cap_n.
//   b with -lo_b <= max(floor_n, lo_a) is dropped (n becomes a); a is kept
//   even when it could go (n would become -b, for which there is no node).
// - smooth_min(a, b, k) = min(a, b) - h^2 k / 4, h = max(k - |a - b|, 0) / k:
//   where a >= b + k, h = 0 and the value is b, whatever a is above b + k.
//   So a may get cap hi_b + k (no floor: values of a below it all matter):
//   it is dropped when lo_a >= hi_b + k, i.e. when it lies farther than the
//   blend radius above every value of the other operand. It may also get
//   a cap T from cap_n: where a >= T, either b <= T - k, so a and any
//   g >= T lie at least k above b and both smooth minima are b; or
//   b > T - k, and then (the smooth minimum is monotone in each operand: its
//   partial derivatives are h/2 and 1 - h/2) both smooth minima are at
//   least f(T) = smooth_min(T, max(lo_b, T - k)), which is >= cap_n for
//   T >= cap_n + k always, for T = cap_n when lo_b >= cap_n + k, and in
//   between for T = lo_b + k - 2 sqrt(k (lo_b - cap_n)), where f(T) = cap_n
//   (solving the polynomial; smooth_cap()). a gets the smaller of the two
//   caps. Without the lower bound of b, each level of a chain of kept
//   operands would loosen the cap by k.
// - a smooth union group (sdf_program.h: the smooth minimum folded over
//   the smallest operand values in increasing order, from m, the least of
//   them): the fold so far never exceeds m, and m <= hi_j for every
//   operand j, so where operand b >= hi_j + k for some other j, b lies a
//   blend above the fold when its turn comes, h = 0, and neither b nor any
//   value after it changes the fold; a replacement g >= hi_j + k does the
//   same, and keeps b out of the smallest values' set or in it without
//   effect. So b gets cap min_{j != b} hi_j + k (no floor) and is dropped
//   when lo_b reaches it; a group left with one operand becomes it.
// - smooth_max(a, b, k) = -smooth_min(-a, -b, k): a gets the mirrored
//   floor max(lo_b - k, -smooth_cap(-floor_n, -hi_b)) and is dropped when
//   its hi is below it. Smooth subtraction smooth_max(a, -b, k) is the same
//   with -b in [-hi_b, -lo_b]; b gets the negated floor of -b as its cap,
//   and is dropped when -lo_b is below that floor.
// - round (a - r): cap and floor move by r. transform (s a, s > 0): they are
//   divided by s. onion (|a| - t) is not monotone: its operand gets none.
//
// - The math clauses min and max follow the min and max rules, unless an
//   operand may be NaN (its interval is entire): then both stay, with no cap
//   or floor, since a NaN compares with nothing. Other math clauses are not
//   monotone in general: their operands get no cap or floor.
// - A clause read by several users (tapes are DAGs) takes the largest cap
//   and the smallest floor any user gives it: a replacement that keeps every
//   user's value where it matters to that user.
//
// Each rule replaces values only where the operator's value is unchanged (or
// stays on the same side of n's own cap or floor), so by induction from the
// root the simplified tape equals the whole one at every point of the box.
// Primitive intervals are widened by a small relative margin against float
// rounding (sdf_shape_margin).

#include "sdf_simplify.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "sdf_tape_eval.h"

namespace implicit {

namespace {

// What becomes of a clause.
enum clause_state : char { unreached = 0, kept = 1, folded = 2 };

// The cap that a smooth-min operand a inherits from its node's cap C when
// the other operand is at least `lo_other` (see the proof above): the least
// T with smooth_min(T, max(lo_other, T - k)) >= C.
float smooth_cap(float cap, float lo_other, float k) {
  if (k <= 0) return cap;
  auto d = lo_other - cap;
  if (!(d > 0)) return cap + k;
  if (d >= k) return cap;
  return lo_other + k - 2 * std::sqrt(k * d);
}

// Pass 1: the interval of every clause over the box, bottom-up.
void bound_clauses(const sdf_tape& pool, const std::vector<sdf_ssa>& ssa,
    const bbox3f& box, sdf_simplify_state& state) {
  // Scratch only grows: slots are written before they are read.
  auto n = ssa.size();
  if (state.values.size() < n) {
    state.values.resize(n);
    state.points.resize(n);
    state.groups.resize(n);
  }
  run_sdf_clauses(pool, ssa.data(), ssa.data() + n, state.values.data(),
      state.points.data(), state.groups.data(), make_box_point(box), 0.0f);
}

// The top-down walk of pass 2 at one clause.
struct cap_walk {
  sdf_simplify_state& state;
  int                 node = 0;

  float lo(int k) const { return state.values[k].lo; }
  float hi(int k) const { return state.values[k].hi; }
  float cap() const { return state.caps[node]; }
  float floor() const { return state.floors[node]; }
  bool  entire(int k) const { return is_entire(state.values[k]); }

  // Operand k is kept with cap c and floor f (the loosest over its users).
  void keep(int k, float c, float f) {
    if (state.state[k] == unreached) {
      state.state[k]  = kept;
      state.caps[k]   = c;
      state.floors[k] = f;
    } else {
      state.caps[k]   = std::max(state.caps[k], c);
      state.floors[k] = std::min(state.floors[k], f);
    }
  }
  void keep(int k) { keep(k, flt_inf, -flt_inf); }
  // The clause becomes operand k, which inherits its cap and floor.
  void become(int k) {
    state.pass[node] = k;
    keep(k, cap(), floor());
  }

  void min_rule(int a, int b) {
    if (entire(a) || entire(b)) return keep(a), keep(b);
    if (lo(a) >= std::min(cap(), hi(b))) return become(b);
    if (lo(b) >= std::min(cap(), hi(a))) return become(a);
    keep(a, std::min(cap(), hi(b)), floor());
    keep(b, std::min(cap(), hi(a)), floor());
  }
  void max_rule(int a, int b) {
    if (entire(a) || entire(b)) return keep(a), keep(b);
    if (hi(a) <= std::max(floor(), lo(b))) return become(b);
    if (hi(b) <= std::max(floor(), lo(a))) return become(a);
    keep(a, cap(), std::max(floor(), lo(b)));
    keep(b, cap(), std::max(floor(), lo(a)));
  }
  void subtraction_rule(int a, int b) {
    if (entire(a) || entire(b)) return keep(a), keep(b);
    if (-lo(b) <= std::max(floor(), lo(a))) return become(a);
    keep(a, cap(), std::max(floor(), -hi(b)));
    keep(b, -std::max(floor(), lo(a)), -cap());
  }
  void smooth_union_rule(int a, int b, float k) {
    if (entire(a) || entire(b)) return keep(a), keep(b);
    auto reach_a = smooth_cap(cap(), lo(b), k);
    auto reach_b = smooth_cap(cap(), lo(a), k);
    if (lo(a) >= std::min(hi(b) + k, reach_a)) return become(b);
    if (lo(b) >= std::min(hi(a) + k, reach_b)) return become(a);
    keep(a, std::min(hi(b) + k, reach_a), -flt_inf);
    keep(b, std::min(hi(a) + k, reach_b), -flt_inf);
  }
  // A group (its close clause here): see the proof above.
  void smooth_group_rule(const std::vector<sdf_ssa>& ssa, float k) {
    auto& chain = state.chain;
    chain.clear();
    auto least = flt_inf, second = flt_inf;  // the two least upper ends
    auto entire_operand = false;
    auto open           = ssa[node].a;
    for (; ssa[open].op == sdf_op::smooth_add; open = ssa[open].a) {
      chain.push_back(open);
      auto b = ssa[open].b;
      entire_operand |= entire(b);
      second = std::max(least, std::min(second, hi(b)));
      least  = std::min(least, hi(b));
    }
    // The reach of operand b: a blend above the least upper end of the
    // others; the one with the least upper end always matters.
    auto reach = [&](int b) {
      if (entire_operand) return flt_inf;
      return (hi(b) == least ? second : least) + k;
    };
    auto matters = [&](int b) { return lo(b) < reach(b) || hi(b) == least; };
    auto count   = 0;
    auto last    = invalidid;
    for (auto add : chain) {
      if (!matters(ssa[add].b)) continue;
      count++;
      last = ssa[add].b;
    }
    if (count == 1) return become(last);
    state.state[open] = kept;
    for (auto add : chain) {
      auto b           = ssa[add].b;
      state.state[add] = kept;
      if (matters(b)) {
        keep(b, reach(b), -flt_inf);
      } else {
        state.pass[add] = ssa[add].a;
      }
    }
  }
  void smooth_intersection_rule(int a, int b, float k) {
    if (entire(a) || entire(b)) return keep(a), keep(b);
    auto reach_a = -smooth_cap(-floor(), -hi(b), k);
    auto reach_b = -smooth_cap(-floor(), -hi(a), k);
    if (hi(a) <= std::max(lo(b) - k, reach_a)) return become(b);
    if (hi(b) <= std::max(lo(a) - k, reach_b)) return become(a);
    keep(a, flt_inf, std::max(lo(b) - k, reach_a));
    keep(b, flt_inf, std::max(lo(a) - k, reach_b));
  }
  void smooth_subtraction_rule(int a, int b, float k) {
    if (entire(a) || entire(b)) return keep(a), keep(b);
    // The operands are a and c = -b, c in [-hi_b, -lo_b].
    auto reach_a = -smooth_cap(-floor(), lo(b), k);
    auto reach_c = -smooth_cap(-floor(), -hi(a), k);
    if (-lo(b) <= std::max(lo(a) - k, reach_c)) return become(a);
    keep(a, flt_inf, std::max(-hi(b) - k, reach_a));
    keep(b, -std::max(lo(a) - k, reach_c), -flt_inf);
  }
};

// A math clause's rule: min and max as CSG, `and` and `or` become the
// operand that interval arithmetic decides; other math clauses are not
// monotone: their operands are kept without caps.
static void cap_math_clause(cap_walk& walk, const sdf_ssa& c) {
  auto is_logic = c.op == sdf_op::math_and || c.op == sdf_op::math_or;
  auto first    = is_logic ? walk.state.values[c.a] : interval{};
  if (c.op == sdf_op::math_min) {
    walk.min_rule(c.a, c.b);
  } else if (c.op == sdf_op::math_max) {
    walk.max_rule(c.a, c.b);
  } else if (c.op == sdf_op::math_and && !may_be_zero(first)) {
    walk.become(c.b);  // and: a if a == 0, else b
  } else if (c.op == sdf_op::math_or && !may_be_zero(first)) {
    walk.become(c.a);  // or: a if a != 0 (NaN included), else b
  } else if (c.op == sdf_op::math_or && always_zero(first)) {
    walk.become(c.b);
  } else {
    for (auto input = 0; input < sdf_op_inputs(c.op); input++)
      walk.keep(input == 0 ? c.a : c.b);
  }
}

// Pass 2: caps, floors, dropped operands and constants, top-down from the
// root (users come after what they read, so a reverse pass sees every user
// of a clause before the clause).
void propagate_caps(
    const std::vector<sdf_ssa>& ssa, sdf_simplify_state& state) {
  // Caps and floors are written when a clause is first reached (keep()):
  // only the root's are set here.
  auto n = (int)ssa.size();
  if ((int)state.caps.size() < n) {
    state.caps.resize(n);
    state.floors.resize(n);
  }
  state.pass.assign(n, invalidid);
  state.state.assign(n, unreached);
  state.state[n - 1]  = kept;
  state.caps[n - 1]   = flt_inf;
  state.floors[n - 1] = -flt_inf;
  for (auto i = n - 1; i >= 0; i--) {
    if (state.state[i] == unreached) continue;
    auto& c     = ssa[i];
    auto  value = state.values[i];
    // One number over the whole box: a constant.
    if (!is_point_op(c.op) && !is_group_op(c.op) &&
        c.op != sdf_op::math_const && is_single(value) &&
        std::isfinite(value.lo)) {
      state.state[i] = folded;
      continue;
    }
    auto walk = cap_walk{state, i};
    auto k    = std::max(sdf_param_float(c.param), 0.0f);
    switch (c.op) {
      case sdf_op::input:
      case sdf_op::smooth_open:
      case sdf_op::smooth_add: break;  // the group's close kept its operands
      case sdf_op::smooth_close: walk.smooth_group_rule(ssa, k); break;
      case sdf_op::csg_union: walk.min_rule(c.a, c.b); break;
      case sdf_op::csg_intersection: walk.max_rule(c.a, c.b); break;
      case sdf_op::csg_subtraction: walk.subtraction_rule(c.a, c.b); break;
      case sdf_op::csg_smooth_union: walk.smooth_union_rule(c.a, c.b, k); break;
      case sdf_op::csg_smooth_intersection:
        walk.smooth_intersection_rule(c.a, c.b, k);
        break;
      case sdf_op::csg_smooth_subtraction:
        walk.smooth_subtraction_rule(c.a, c.b, k);
        break;
      case sdf_op::csg_round: {
        auto r = sdf_param_float(c.param);
        walk.keep(c.a, walk.cap() + r, walk.floor() + r);
        break;
      }
      case sdf_op::scale: {
        auto s = sdf_param_float(c.param);
        if (s > 0) {
          walk.keep(c.a, walk.cap() / s, walk.floor() / s);
        } else {
          walk.keep(c.a);
        }
        break;
      }
      case sdf_op::map:
      case sdf_op::twist:
      case sdf_op::bend:
      case sdf_op::repeat:
      case sdf_op::elongate:
      case sdf_op::mirror:
      case sdf_op::shape:
      case sdf_op::csg_onion:
        walk.keep(c.a);
        break;
        IMPLICIT_SDF_MATH_OP_CASES
        IMPLICIT_SDF_IMMEDIATE_CASES
        cap_math_clause(walk, c);
        break;
    }
  }
}

// Pass 3: the kept clauses in their order (inputs stay before their users),
// each clause that became another replaced by it, constants folded.
void emit_clauses(const std::vector<sdf_ssa>& ssa, sdf_simplify_state& state,
    std::vector<sdf_ssa>& simplified) {
  auto n      = (int)ssa.size();
  auto target = [&](int k) { return state.pass[k] >= 0 ? state.pass[k] : k; };
  // Only kept clauses are read, each after it got its place.
  if ((int)state.index.size() < n) state.index.resize(n);
  auto start = (int)simplified.size();
  for (auto i = 0; i < n; i++) {
    // Passes chain downwards (a clause becomes an earlier one, whose pass
    // is resolved by now).
    auto& pass = state.pass[i];
    if (pass >= 0 && state.pass[pass] >= 0) pass = state.pass[pass];
    if (state.state[i] == unreached || pass >= 0) continue;
    state.index[i] = (int)simplified.size() - start;
    if (state.state[i] == folded) {
      simplified.push_back({sdf_op::math_const, invalidid, invalidid,
          sdf_float_param(state.values[i].lo)});
      continue;
    }
    // Copied, then its operands renamed in place: a clause assembled on
    // the stack and pushed was read back whole before its last stores
    // landed (a store-forwarding stall: 1.6% of the 10,000-sphere preview).
    auto& clause = simplified.emplace_back(ssa[i]);
    auto  inputs = sdf_op_inputs(clause.op);
    if (inputs >= 1) clause.a = state.index[target(clause.a)];
    if (inputs >= 2) clause.b = state.index[target(clause.b)];
  }
}

}  // namespace

interval simplify_sdf(const sdf_tape& pool, const std::vector<sdf_ssa>& ssa,
    const bbox3f& box, sdf_simplify_state& state,
    std::vector<sdf_ssa>& simplified, float far) {
  if (ssa.empty()) return entire_interval;
  bound_clauses(pool, ssa, box, state);
  auto range = state.values[ssa.size() - 1];
  if (is_far(range, far)) return range;
  propagate_caps(ssa, state);
  emit_clauses(ssa, state, simplified);
  return range;
}

sdf_tape simplify_sdf(const sdf_tape& tape, const bbox3f& box) {
  auto simplified = tape;
  auto state      = sdf_simplify_state{};
  simplified.ssa.clear();
  simplified.clauses.clear();
  simplify_sdf(tape, tape.ssa, box, state, simplified.ssa);
  // A subset of a tape that fits its registers fits them too.
  allocate_sdf_registers(simplified.ssa, simplified.clauses);
  return simplified;
}

}  // namespace implicit
