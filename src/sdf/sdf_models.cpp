// # implicit: large procedural SDF models (implementation)

#include "sdf_models.h"

#include <cmath>

#include "../math/random.h"

namespace implicit {

// Fold `leaf` into `root` with `op` (the first leaf becomes the root).
static int fold(sdf_program& program, int root, int leaf, sdf_node op) {
  if (root == invalidid) return leaf;
  op.left  = root;
  op.right = leaf;
  return add_node(program, op);
}

// A primitive moved so that its local origin sits at `at`.
static int place(sdf_program& program, const sdf_node& node, vec3f at) {
  return add_transform(program, add_node(program, node),
      frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -at});
}

sdf_program make_sdf_model(sdf_model_type type, int count, uint64_t seed) {
  auto program = sdf_program{};
  auto rng     = make_rng(seed);
  auto root    = invalidid;
  switch (type) {
    case sdf_model_type::hard_union:
    case sdf_model_type::smooth_union: {
      // Grid of n^3 >= count cells over [-1,1]^3, one operand per cell.
      auto n       = (int)std::ceil(std::cbrt((double)count) - 1e-9);
      auto spacing = 2.0f / n;
      auto op      = sdf_node{};
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
        root = fold(program, root, place(program, node, at), op);
      }
      break;
    }
    case sdf_model_type::perforated_slab: {
      auto n       = (int)std::ceil(std::sqrt((double)count) - 1e-9);
      auto spacing = 2.0f / n;
      auto slab    = sdf_node{};
      slab.type    = sdf_type::box;
      slab.size    = {2, 0.2f, 2};
      root         = place(program, slab, {-1, -0.1f, -1});
      auto op      = sdf_node{};
      op.type      = sdf_type::op_subtraction;
      for (auto i = 0; i < count; i++) {
        auto cylinder   = sdf_node{};
        cylinder.type   = sdf_type::cylinder;
        cylinder.height = 0.2f;
        cylinder.radius = 0.3f * spacing;
        auto at         = vec3f{((float)(i % n) + 0.5f) * spacing - 1, 0,
            ((float)(i / n) + 0.5f) * spacing - 1};
        root            = fold(program, root, place(program, cylinder, at), op);
      }
      break;
    }
  }
  return program;
}

}  // namespace implicit
