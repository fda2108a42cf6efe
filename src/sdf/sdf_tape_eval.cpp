// # implicit: SDF tapes (evaluation at points)

#include "sdf_tape_eval.h"

#include <cassert>

namespace implicit {

// -----------------------------------------------------------------------------
// POINTS
// -----------------------------------------------------------------------------

float eval_sdf(const sdf_tape& tape, vec3f p) {
  assert(!tape.clauses.empty());
  return run_sdf_tape<float>(
      tape, tape.clauses.data(), tape.clauses.data() + tape.clauses.size(), p);
}

float eval_sdf(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, vec3f p) {
  return run_sdf_tape<float>(pool, begin, end, p);
}

namespace {

// Values at `count` points, N per pass; lanes past the last point repeat it
// (their values are dropped).
template <int N>
void eval_sdf_lanes(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const vec3f* points, float* values, size_t count) {
  for (size_t start = 0; start < count; start += N) {
    auto lanes = std::min(count - start, (size_t)N);
    auto batch = sdf_lane_points_of<N>{};
    for (auto i = 0; i < N; i++) {
      auto& q    = points[start + std::min((size_t)i, lanes - 1)];
      batch.x[i] = q.x;
      batch.y[i] = q.y;
      batch.z[i] = q.z;
    }
    auto result = run_sdf_tape<sdf_lanes_of<N>>(pool, begin, end, batch);
    for (size_t i = 0; i < lanes; i++) values[start + i] = result.v[i];
  }
}

}  // namespace

void eval_sdf(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const vec3f* points, float* values, size_t count) {
  // A few points (a march's batch along one ray) take narrow lanes: wide
  // ones would evaluate copies of the last point.
  if (count <= (size_t)sdf_march_lane_count) {
    eval_sdf_lanes<sdf_march_lane_count>(
        pool, begin, end, points, values, count);
  } else {
    eval_sdf_lanes<sdf_lane_count>(pool, begin, end, points, values, count);
  }
}

void eval_sdf(
    const sdf_tape& tape, const vec3f* points, float* values, size_t count) {
  assert(!tape.clauses.empty());
  eval_sdf(tape, tape.clauses.data(), tape.clauses.data() + tape.clauses.size(),
      points, values, count);
}

vec3f eval_sdf_gradient(const sdf_tape& tape, vec3f p, float step) {
  auto g     = vec3f{};
  auto shape = sdf_node{};
  auto begin = tape.clauses.data(), end = begin + tape.clauses.size();
  if (is_single_shape(tape, begin, end, shape) &&
      eval_primitive_gradient(shape, p, g))
    return g;
  return normalize(tetrahedral_gradient(
      [&](vec3f q) { return eval_sdf(tape, q); }, p, step));
}

float eval_sdf_math(sdf_op op, float a, float b) {
  switch (op) {
    // clang-format off
#define IMPLICIT_SDF_FOLD_0(id)
#define IMPLICIT_SDF_FOLD_1(id) case sdf_op::id: return id(a);
#define IMPLICIT_SDF_FOLD_2(id) case sdf_op::id: return id(a, b);
#define IMPLICIT_SDF_FOLD(id, name, operands) IMPLICIT_SDF_FOLD_##operands(id)
    IMPLICIT_SDF_MATH(IMPLICIT_SDF_FOLD)
    // clang-format on
#undef IMPLICIT_SDF_FOLD
#undef IMPLICIT_SDF_FOLD_2
#undef IMPLICIT_SDF_FOLD_1
#undef IMPLICIT_SDF_FOLD_0
    case sdf_op::math_const:
      return a;
      IMPLICIT_SDF_POINT_CASES
      IMPLICIT_SDF_DISTANCE_CASES
      IMPLICIT_SDF_IMMEDIATE_CASES
    case sdf_op::math_x:
    case sdf_op::math_y:
    case sdf_op::math_z: break;
  }
  assert(false && "eval_sdf_math on a clause that is no math on values");
  return 0;
}

}  // namespace implicit
