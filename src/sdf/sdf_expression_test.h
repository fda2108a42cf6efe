// # implicit: a reference evaluator of math clauses, for tests
//
// Evaluates the math clauses of a program in double precision, node by
// node in array order, from the meaning sdf_program.h documents (written
// again here, independently of the tape). Only for tests of the parsers:
// a node that is not a math clause gives NaN.
#pragma once

#include <cmath>
#include <vector>

#include "sdf_program.h"

namespace implicit {

// Value of `root` at p; nodes before `root` that it does not reach are
// evaluated too (programs of the parsers are small).
inline double eval_reference(const sdf_program& program, int root, vec3f p) {
  auto values = std::vector<double>(root + 1, NAN);
  for (auto i = 0; i <= root; i++) {
    auto& node = program.nodes[i];
    auto  a    = node.left >= 0 ? values[node.left] : NAN;
    auto  b    = node.right >= 0 ? values[node.right] : NAN;
    auto  nan2 = std::isnan(a) || std::isnan(b);
    auto& v    = values[i];
    switch (node.type) {
      case sdf_type::math_const: v = node.value; break;
      case sdf_type::math_x: v = p.x; break;
      case sdf_type::math_y: v = p.y; break;
      case sdf_type::math_z: v = p.z; break;
      case sdf_type::math_neg: v = -a; break;
      case sdf_type::math_abs: v = std::abs(a); break;
      case sdf_type::math_square: v = a * a; break;
      case sdf_type::math_sqrt: v = std::sqrt(a); break;
      case sdf_type::math_exp: v = std::exp(a); break;
      case sdf_type::math_log: v = std::log(a); break;
      case sdf_type::math_sin: v = std::sin(a); break;
      case sdf_type::math_cos: v = std::cos(a); break;
      case sdf_type::math_tan: v = std::tan(a); break;
      case sdf_type::math_asin: v = std::asin(a); break;
      case sdf_type::math_acos: v = std::acos(a); break;
      case sdf_type::math_atan: v = std::atan(a); break;
      case sdf_type::math_floor: v = std::floor(a); break;
      case sdf_type::math_ceil: v = std::ceil(a); break;
      case sdf_type::math_round: v = std::round(a); break;
      case sdf_type::math_not: v = a == 0 ? 1 : 0; break;
      case sdf_type::math_add: v = a + b; break;
      case sdf_type::math_sub: v = a - b; break;
      case sdf_type::math_mul: v = a * b; break;
      case sdf_type::math_div: v = a / b; break;
      case sdf_type::math_min: v = nan2 ? NAN : std::min(a, b); break;
      case sdf_type::math_max: v = nan2 ? NAN : std::max(a, b); break;
      case sdf_type::math_atan2: v = std::atan2(a, b); break;
      case sdf_type::math_mod: {
        auto r = std::fmod(a, b);
        v      = r < 0 ? r + std::abs(b) : r;
        break;
      }
      case sdf_type::math_compare:
        v = nan2 ? NAN : a < b ? -1 : a > b ? 1 : 0;
        break;
      case sdf_type::math_and: v = a == 0 ? a : b; break;
      case sdf_type::math_or:
        v = a != 0 ? a : b;
        break;
        IMPLICIT_SDF_PRIMITIVE_CASES
        IMPLICIT_SDF_CSG_CASES
        IMPLICIT_SDF_WARP_CASES v = NAN;
        break;
    }
  }
  return values[root];
}

inline double eval_reference(const sdf_program& program, vec3f p) {
  return eval_reference(program, root_node(program), p);
}

}  // namespace implicit
