// # implicit: SDF tapes (derivatives and bounds over boxes)

#include <algorithm>
#include <cassert>
#include <cmath>

#include "sdf_tape_eval.h"

namespace implicit {

// -----------------------------------------------------------------------------
// DERIVATIVES AT POINTS
// -----------------------------------------------------------------------------

dual<float> eval_sdf_dual(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p) {
  auto point = sdf_vec3<dual<float>>{make_dual_variable(p.x, 0),
      make_dual_variable(p.y, 1), make_dual_variable(p.z, 2)};
  return run_sdf_tape<dual<float>>(pool, begin, end, point, sdf_shape_step);
}

dual<float> eval_sdf_dual(const sdf_tape& tape, vec3f p) {
  assert(!tape.clauses.empty());
  return eval_sdf_dual(
      tape, tape.clauses.data(), tape.clauses.data() + tape.clauses.size(), p);
}

dual<float, 1> eval_sdf_slope(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p, vec3f direction) {
  auto point = sdf_vec3<dual<float, 1>>{make_dual_along(p.x, direction.x),
      make_dual_along(p.y, direction.y), make_dual_along(p.z, direction.z)};
  return run_sdf_tape<dual<float, 1>>(pool, begin, end, point, sdf_shape_step);
}

void eval_sdf_gradients(const sdf_tape& tape, const vec3f* points,
    float* values, vec3f* gradients, size_t count) {
  for (size_t i = 0; i < count; i++) {
    auto d       = eval_sdf_dual(tape, points[i]);
    values[i]    = d.v;
    gradients[i] = gradient(d);
  }
}

// -----------------------------------------------------------------------------
// BOXES
// -----------------------------------------------------------------------------

interval eval_sdf_interval(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box) {
  return run_sdf_tape<interval>(pool, begin, end, make_box_point(box));
}

interval eval_sdf_interval(const sdf_tape& tape, const bbox3f& box) {
  return eval_sdf_interval(tape, tape.clauses.data(),
      tape.clauses.data() + tape.clauses.size(), box);
}

dual<interval> eval_sdf_dual(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box) {
  return run_sdf_tape<dual<interval>>(
      pool, begin, end, make_dual_box_point(box), sdf_shape_step);
}

dual<interval> eval_sdf_dual(const sdf_tape& tape, const bbox3f& box) {
  return eval_sdf_dual(tape, tape.clauses.data(),
      tape.clauses.data() + tape.clauses.size(), box);
}

dual<interval, 1> eval_sdf_slope(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box, vec3f direction) {
  return run_sdf_tape<dual<interval, 1>>(
      pool, begin, end, make_dual_box_point(box, direction), sdf_shape_step);
}

float eval_sdf_lipschitz(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const bbox3f& box) {
  return gradient_bound(eval_sdf_dual(pool, begin, end, box));
}

float eval_sdf_lipschitz(const sdf_tape& tape, const bbox3f& box) {
  return eval_sdf_lipschitz(tape, tape.clauses.data(),
      tape.clauses.data() + tape.clauses.size(), box);
}

// -----------------------------------------------------------------------------
// JUMPS
// -----------------------------------------------------------------------------

// Where v, moving linearly from v0 to v1, first passes a value k + offset
// (k an integer): the fraction in (0, 1), or NaN if it passes none.
static float first_crossing(float v0, float v1, float offset) {
  if (!(std::isfinite(v0) && std::isfinite(v1)) || v0 == v1) return flt_nan;
  auto border = v1 > v0 ? std::floor(v0 - offset) + 1 + offset
                        : std::ceil(v0 - offset) - 1 + offset;
  auto u      = (border - v0) / (v1 - v0);
  return u > 0 && u < 1 ? u : flt_nan;
}

// Where the input of a repeat clause first changes copy (see above).
static float repeat_crossing(const sdf_node& node, vec3f q0, vec3f q1) {
  int  counts[3] = {node.count.x, node.count.y, node.count.z};
  auto nearest   = flt_nan;
  for (auto a = 0; a < 3; a++) {
    auto size = at(node.size, a);
    if (!(size > 0)) continue;
    auto n0 = repeat_copy(at(q0, a), size, counts[a]);
    auto n1 = repeat_copy(at(q1, a), size, counts[a]);
    if (!(n0 != n1) || !(n0 == n0 && n1 == n1)) continue;
    // The first border from q0's copy towards q1's.
    auto border = (n0 + (n1 > n0 ? 0.5f : -0.5f)) * size;
    auto u      = (border - at(q0, a)) / (at(q1, a) - at(q0, a));
    if (u > 0 && u < 1 && !(u >= nearest)) nearest = u;
  }
  return nearest;
}

// Where a jumping math clause's inputs (values v, w in two register files)
// first reach a jump: floor and ceil at integers, round half way between,
// mod(a, b) where a / |b| is an integer, compare where a - b is 0.
static float math_crossing(
    const sdf_clause& c, const float* values0, const float* values1) {
  auto a0 = values0[c.a], a1 = values1[c.a];
  switch (c.op) {
    case sdf_op::math_floor:
    case sdf_op::math_ceil: return first_crossing(a0, a1, 0);
    case sdf_op::math_round: return first_crossing(a0, a1, 0.5f);
    case sdf_op::math_mod: {
      auto b0 = std::abs(values0[c.b]), b1 = std::abs(values1[c.b]);
      return first_crossing(a0 / b0, a1 / b1, 0);
    }
    case sdf_op::math_compare: {
      auto d0 = a0 - values0[c.b], d1 = a1 - values1[c.b];
      if (!((d0 < 0 && d1 > 0) || (d0 > 0 && d1 < 0))) return flt_nan;
      return d0 / (d0 - d1);
    }
    default: return flt_nan;
  }
}

float find_sdf_jump(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p0, vec3f p1) {
  // The tape at both ends, run up to each jumping clause in turn, whose
  // inputs are then in the registers.
  float             values0[sdf_max_registers], values1[sdf_max_registers];
  vec3f             points0[sdf_max_points], points1[sdf_max_points];
  sdf_smooth_floats groups0[sdf_max_groups], groups1[sdf_max_groups];
  auto              nearest = flt_nan;
  auto              done    = begin;
  if (!pool.jumps) return nearest;  // the tape's clauses, and any subset
  for (auto c = begin; c != end; ++c) {
    if (!is_jump_op(c->op)) continue;
    run_sdf_clauses(pool, done, c, values0, points0, groups0, p0, 0.0f);
    run_sdf_clauses(pool, done, c, values1, points1, groups1, p1, 0.0f);
    done   = c;
    auto u = c->op == sdf_op::repeat ? repeat_crossing(pool.nodes[c->param],
                                           points0[c->a], points1[c->a])
                                     : math_crossing(*c, values0, values1);
    if (u > 0 && u < 1 && !(u >= nearest)) nearest = u;
  }
  return nearest;
}

}  // namespace implicit
