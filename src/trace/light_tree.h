// # implicit: a bounding volume hierarchy over emitters
//
// Picks one of many emitters with a probability that follows how much each
// can contribute at a shading point, after Conty Estevez and Kulla,
// "Importance Sampling of Many Lights with Adaptive Tree Splitting" (2018),
// as pbrt-v4's BVHLightSampler does. Every node bounds its emitters by a box,
// their total power and a cone of their surface normals; its importance at a
// point is power * cos(theta') * falloff(d), the falloff the mean of 1 / d^2
// over a ball of emitters (light_importance), where theta' is the smallest
// angle between a normal of the cone and the direction to the point that the
// box allows (zero beyond 90 degrees: emission is Lambertian), times the
// smallest cosine at the receiver that the box allows. Sampling walks down
// from the root choosing a child in proportion to its importance; the
// probability of an emitter is the product of the choices on its path, which
// light_tree_probability() recomputes from the emitter's bit trail with the
// same arithmetic, so the two agree to the bit.
//
// The importance is a heuristic: zero where an emitter still lights the
// point only costs light sampling there. Multiple importance sampling gives
// BSDF samples full weight wherever the light pdf is zero, so no estimate is
// biased by it.
#pragma once

#include <cstdint>
#include <vector>

#include "../math/math.h"

namespace implicit {

// -----------------------------------------------------------------------------
// BOUNDS
// -----------------------------------------------------------------------------

// What one emitter or a node of them may emit: a box around the emitting
// surfaces, their power, and their normals, all within acos(cos_spread) of
// `axis` (or of -axis too, for `two_sided`); cos_spread = -1 is any normal.
// `reach` bounds every point the light samplers aim at, so a ray that misses
// it has no light pdf from this node.
struct light_bounds {
  bbox3f bounds     = invalid_bbox;
  bbox3f reach      = invalid_bbox;
  float  power      = 0;
  vec3f  axis       = {0, 0, 1};
  float  cos_spread = 1;
  bool   two_sided  = false;
};

// Bounds of both (boxes merged, powers added, the smallest cone holding
// both cones).
light_bounds merge(const light_bounds& a, const light_bounds& b);

// Set the cone of `bounds` to hold unit normals: one-sided, or two-sided
// (n or -n within the cone) when only that is narrower than a hemisphere,
// widened by `margin` radians; any direction when there are none.
void bound_normals(
    const std::vector<vec3f>& normals, float margin, light_bounds& bounds);

// -----------------------------------------------------------------------------
// TREE
// -----------------------------------------------------------------------------

// A node, as its importance reads it: the sphere around its box, its power
// and its normals' cone (with the sine too: no square root per visit). A
// leaf holds one emitter (`index` in the list the tree was made from), an
// interior node its two children at `index` and `index + 1` (one cache line
// pair for each choice).
struct light_node {
  vec3f center     = {0, 0, 0};
  float radius2    = 0;
  vec3f axis       = {0, 0, 1};
  float cos_spread = -1;
  float sin_spread = 0;
  float power      = 0;
  int   index      = invalidid;
  bool  leaf       = false;
  bool  two_sided  = false;
};

// The node of some bounds (index and leaf unset).
light_node make_light_node(const light_bounds& bounds);

// Importance of a node at `position`, for a receiver whose normal (toward
// the side it scatters to) is `normal`, or {0, 0, 0} for a receiver that
// scatters to every side (transmission, media).
float light_importance(const light_node& node, vec3f position, vec3f normal);

// The tree, nodes in build order (a parent before its children), the reach
// of every node (for rays, see visit_light_tree), and for each emitter its
// leaf (invalidid: none) and the path from the root to it: bit k set means
// the second child at depth k.
struct light_tree {
  std::vector<light_node> nodes   = {};
  std::vector<bbox3f>     reaches = {};
  std::vector<int>        leaves  = {};
  std::vector<uint64_t>   trails  = {};
};

// Build the tree over emitters with positive power (the others get no leaf
// and probability 0). Splits minimise pbrt-v4's cost (power times the solid
// angle the normals may emit to times the box's area, over buckets of
// centroids); below depth 32 they halve the count instead, so no trail needs
// more than 64 bits.
light_tree make_light_tree(const std::vector<light_bounds>& emitters);

// Deepest leaf (the bits of a trail).
inline constexpr int light_tree_max_depth = 64;

// An emitter picked by `r`, and the probability it had (0 and invalidid when
// no emitter can light the point).
struct light_pick {
  int   index       = invalidid;
  float probability = 0;
};

// Walk down from the root choosing children by importance; `r` is reused
// (rescaled) at each level.
light_pick sample_light_tree(
    const light_tree& tree, vec3f position, vec3f normal, float r);

// Probability that sample_light_tree() picks emitter `index`.
float light_tree_probability(
    const light_tree& tree, int index, vec3f position, vec3f normal);

// Whether a ray from `origin` along `direction` can meet a box: the origin
// is inside, or the line enters it ahead of the origin.
bool may_reach(const bbox3f& box, vec3f origin, vec3f direction);

// Call visit(index, probability) for every emitter whose reach the ray from
// `position` along `direction` meets, in a fixed order. `weighted`: with the
// probability that sample_light_tree() picks it (the same products, so the
// same floats), skipping those it never picks; else with probability 1 and
// no importance computed (other pickers prune by reach alone). An explicit
// stack: no recursion.
template <typename Visit>
inline void visit_light_tree(const light_tree& tree, vec3f position,
    vec3f normal, vec3f direction, bool weighted, const Visit& visit) {
  if (tree.nodes.empty()) return;
  auto& root = tree.nodes[0];
  if (!may_reach(tree.reaches[0], position, direction)) return;
  if (root.leaf) {
    if (!weighted || light_importance(root, position, normal) > 0)
      visit(root.index, 1.0f);
    return;
  }
  struct item {
    int   node        = 0;
    float probability = 1;
  };
  item stack[light_tree_max_depth + 2];  // one pending sibling per level
  auto size     = 0;
  stack[size++] = {0, 1};
  while (size > 0) {
    auto  current = stack[--size];
    auto& node    = tree.nodes[current.node];
    if (node.leaf) {
      visit(node.index, current.probability);
      continue;
    }
    auto& first  = tree.nodes[node.index];
    auto& second = tree.nodes[node.index + 1];
    auto  p0 = 1.0f, p1 = 1.0f;
    if (weighted) {
      auto i0 = light_importance(first, position, normal);
      auto i1 = light_importance(second, position, normal);
      if (i0 + i1 <= 0) continue;
      p0 = i0 / (i0 + i1);
      p1 = i1 / (i0 + i1);
    }
    if (p1 > 0 && may_reach(tree.reaches[node.index + 1], position, direction))
      stack[size++] = {node.index + 1, current.probability * p1};
    if (p0 > 0 && may_reach(tree.reaches[node.index], position, direction))
      stack[size++] = {node.index, current.probability * p0};
  }
}

}  // namespace implicit
