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

// The copy of a repeat that coordinate `x` falls in (repeat_axis's n).
static float repeat_copy(float x, float size, int count) {
  auto n = std::round(x / size);
  return count >= 0 ? std::clamp(n, (float)-count, (float)count) : n;
}

float find_sdf_repeat_border(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p0, vec3f p1) {
  // The point clauses alone, at both ends (registers as the tape has them).
  vec3f points0[sdf_max_points], points1[sdf_max_points];
  auto  nearest = flt_nan;
  for (auto c = begin; c != end; ++c) {
    if (!is_point_op(c->op)) continue;
    if (c->op == sdf_op::input) {
      points0[c->out] = p0;
      points1[c->out] = p1;
      continue;
    }
    if (c->op == sdf_op::map) {
      points0[c->out] = map_point(pool, (int)c->param, points0[c->a]);
      points1[c->out] = map_point(pool, (int)c->param, points1[c->a]);
      continue;
    }
    auto& node = pool.nodes[c->param];
    auto  q0 = points0[c->a], q1 = points1[c->a];
    int   counts[3] = {node.count.x, node.count.y, node.count.z};
    for (auto a = 0; c->op == sdf_op::repeat && a < 3; a++) {
      auto size  = at(node.size, a);
      auto count = counts[a];
      if (!(size > 0)) continue;
      auto n0 = repeat_copy(at(q0, a), size, count);
      auto n1 = repeat_copy(at(q1, a), size, count);
      if (!(n0 != n1) || !(n0 == n0 && n1 == n1)) continue;
      // The first border from q0's copy towards q1's, where the input
      // would cross it moving linearly.
      auto border = (n0 + (n1 > n0 ? 0.5f : -0.5f)) * size;
      auto u      = (border - at(q0, a)) / (at(q1, a) - at(q0, a));
      if (u > 0 && u < 1 && !(u >= nearest)) nearest = u;
    }
    points0[c->out] = warp_point(node, q0);
    points1[c->out] = warp_point(node, q1);
  }
  return nearest;
}

}  // namespace implicit
