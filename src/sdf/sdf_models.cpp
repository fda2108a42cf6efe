// # implicit: large procedural SDF models (implementation)

#include "sdf_models.h"

#include <cmath>

#include "../math/random.h"

namespace implicit {

// A primitive moved so that its local origin sits at `at`.
static int place(sdf_program& program, const sdf_node& node, vec3f at) {
  return add_transform(program, add_node(program, node),
      frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -at});
}

sdf_program make_sdf_model(sdf_model_type type, int count, uint64_t seed) {
  auto program = sdf_program{};
  auto rng     = make_rng(seed);
  auto roots   = std::vector<int>{};  // operands, combined at the end
  auto op      = sdf_node{};
  switch (type) {
    case sdf_model_type::hard_union:
    case sdf_model_type::smooth_union: {
      // Grid of n^3 >= count cells over [-1,1]^3, one operand per cell.
      auto n       = (int)std::ceil(std::cbrt((double)count) - 1e-9);
      auto spacing = 2.0f / n;
      op.type      = type == sdf_model_type::hard_union ? sdf_type::op_union
                                                        : sdf_type::op_smooth_union;
      op.blend     = type == sdf_model_type::hard_union ? 0 : 0.6f * spacing;
      for (auto i = 0; i < count; i++) {
        auto cell =
            vec3f{(float)(i % n), (float)(i / n % n), (float)(i / n / n)};
        auto jx     = rand1f(rng) - 0.5f;
        auto jy     = rand1f(rng) - 0.5f;
        auto jz     = rand1f(rng) - 0.5f;
        auto jitter = vec3f{jx, jy, jz} * 0.3f;
        auto at     = (cell + 0.5f + jitter) * spacing - 1.0f;
        auto node   = sdf_node{};
        if (type == sdf_model_type::hard_union && i % 2 == 1) {
          node.type = sdf_type::box;
          node.size = vec3f{1, 1, 1} * 0.5f * spacing;
          at -= node.size * 0.5f;  // boxes have their corner at the origin
        } else {
          node.type = sdf_type::sphere;
          node.radius =
              (type == sdf_model_type::hard_union ? 0.35f : 0.3f) * spacing;
        }
        roots.push_back(place(program, node, at));
      }
      break;
    }
    case sdf_model_type::perforated_slab: {
      auto n       = (int)std::ceil(std::sqrt((double)count) - 1e-9);
      auto spacing = 2.0f / n;
      auto slab    = sdf_node{};
      slab.type    = sdf_type::box;
      slab.size    = {2, 0.2f, 2};
      roots.push_back(place(program, slab, {-1, -0.1f, -1}));
      op.type = sdf_type::op_subtraction;
      for (auto i = 0; i < count; i++) {
        auto cylinder   = sdf_node{};
        cylinder.type   = sdf_type::cylinder;
        cylinder.height = 0.2f;
        cylinder.radius = 0.3f * spacing;
        auto at         = vec3f{((float)(i % n) + 0.5f) * spacing - 1, 0,
            ((float)(i / n) + 0.5f) * spacing - 1};
        roots.push_back(place(program, cylinder, at));
      }
      break;
    }
  }
  fold_sdf_operands(program, roots, op);
  return program;
}

}  // namespace implicit
