// # implicit: SDF tapes (derivatives and bounds over boxes)

#include <cassert>

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

}  // namespace implicit
