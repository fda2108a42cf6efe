// # implicit: spatial pruning of SDF programs (implementation)
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
// - smooth_max(a, b, k) = -smooth_min(-a, -b, k): a gets the mirrored
//   floor max(lo_b - k, -smooth_cap(-floor_n, -hi_b)) and is dropped when
//   its hi is below it. Smooth subtraction smooth_max(a, -b, k) is the same
//   with -b in [-hi_b, -lo_b]; b gets the negated floor of -b as its cap,
//   and is dropped when -lo_b is below that floor.
// - round (a - r): cap and floor move by r. transform (s a, s > 0): they are
//   divided by s. onion (|a| - t) is not monotone: its operand gets none.
//
// Each rule replaces values only where the operator's value is unchanged (or
// stays on the same side of n's own cap or floor), so by induction from the
// root the pruned program equals the whole one at every point of the box.
// Intervals are widened by a small relative margin against float rounding.

#include "sdf_prune.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <memory>

#include "sdf_primitives.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PRUNING
// -----------------------------------------------------------------------------

// Relative widening of intervals against the rounding of the centre value
// and of the Lipschitz radius.
static constexpr float interval_margin = 1e-4f;

// The cap that a smooth-min operand a inherits from its node's cap C when
// the other operand is at least `lo_other` (see the proof above): the least
// T with smooth_min(T, max(lo_other, T - k)) >= C.
static float smooth_cap(float cap, float lo_other, float k) {
  if (k <= 0) return cap;
  auto d = lo_other - cap;
  if (!(d > 0)) return cap + k;
  if (d >= k) return cap;
  return lo_other + k - 2 * std::sqrt(k * d);
}

sdf_program prune_sdf(const sdf_program& program, const bbox3f& box) {
  auto range = vec2f{};
  return prune_sdf(program, box, range);
}

sdf_program prune_sdf(
    const sdf_program& program, const bbox3f& box, vec2f& range) {
  auto& nodes = program.nodes;
  auto  n     = (int)nodes.size();
  range       = {-flt_inf, flt_inf};
  if (n == 0) return program;
  // Spaces, top-down, as in make_sdf_tape(): the centre and the ball radius
  // in each transform's space.
  auto centre  = center(box);
  auto radius  = length(size(box)) * 0.5f;
  auto space   = std::vector<int>(n, invalidid);
  auto frames  = std::vector<frame3f>{};
  auto stretch = std::vector<float>{};
  for (auto i = n - 1; i >= 0; i--) {
    auto& node  = nodes[i];
    auto  inner = space[i];
    if (node.type == sdf_type::op_transform) {
      // The composed map stretches at most by the product of the stretches,
      // 1 / frame_scale each (no power iteration per cell).
      auto& frame = program.frames[node.frame];
      auto  scale = program.frame_scales[node.frame];
      auto  outer = inner < 0 ? 1.0f : stretch[inner];
      frames.push_back(inner < 0 ? frame : frame * frames[inner]);
      stretch.push_back(scale > 0 ? outer / scale : flt_inf);
      inner = (int)frames.size() - 1;
    }
    if (node.left >= 0) space[node.left] = inner;
    if (node.right >= 0) space[node.right] = inner;
  }

  // Intervals over the box, bottom-up.
  auto lo = std::vector<float>(n), hi = std::vector<float>(n);
  for (auto i = 0; i < n; i++) {
    auto& node = nodes[i];
    auto  l = node.left, r = node.right;
    auto  k = std::max(node.blend, 0.0f);
    switch (node.type) {
      IMPLICIT_SDF_PRIMITIVE_CASES {
        auto s = space[i];
        auto q = s < 0 ? centre : transform_point(frames[s], centre);
        auto v = eval_primitive(node, q);
        auto d = radius * (s < 0 ? 1 : stretch[s]) * primitive_lipschitz(node);
        auto m = interval_margin * (d + std::abs(v));
        lo[i]  = v - d - m;
        hi[i]  = v + d + m;
        break;
      }
      case sdf_type::op_union:
        lo[i] = std::min(lo[l], lo[r]);
        hi[i] = std::min(hi[l], hi[r]);
        break;
      case sdf_type::op_intersection:
        lo[i] = std::max(lo[l], lo[r]);
        hi[i] = std::max(hi[l], hi[r]);
        break;
      case sdf_type::op_subtraction:
        lo[i] = std::max(lo[l], -hi[r]);
        hi[i] = std::max(hi[l], -lo[r]);
        break;
      // The smooth minimum and maximum are monotone in each operand
      // (their partial derivatives are h/2 and 1 - h/2, both in [0, 1]), so
      // their values over the box lie between their values at the ends of
      // the operands' intervals.
      case sdf_type::op_smooth_union:
        lo[i] = smooth_min(lo[l], lo[r], k);
        hi[i] = smooth_min(hi[l], hi[r], k);
        break;
      case sdf_type::op_smooth_intersection:
        lo[i] = smooth_max(lo[l], lo[r], k);
        hi[i] = smooth_max(hi[l], hi[r], k);
        break;
      case sdf_type::op_smooth_subtraction:
        lo[i] = smooth_max(lo[l], -hi[r], k);
        hi[i] = smooth_max(hi[l], -lo[r], k);
        break;
      case sdf_type::op_round:
        lo[i] = lo[l] - node.radius;
        hi[i] = hi[l] - node.radius;
        break;
      case sdf_type::op_onion: {
        auto t = node.thickness;
        if (lo[l] >= 0) {
          lo[i] = lo[l] - t;
          hi[i] = hi[l] - t;
        } else if (hi[l] <= 0) {
          lo[i] = -hi[l] - t;
          hi[i] = -lo[l] - t;
        } else {
          lo[i] = -t;
          hi[i] = std::max(-lo[l], hi[l]) - t;
        }
        break;
      }
      case sdf_type::op_transform: {
        auto s = program.frame_scales[node.frame];
        lo[i]  = lo[l] * s;
        hi[i]  = hi[l] * s;
        break;
      }
        // No tape evaluates these yet (make_sdf_tape() refuses them).
        IMPLICIT_SDF_WARP_CASES
        IMPLICIT_SDF_MATH_CASES
        lo[i] = -flt_inf;
        hi[i] = flt_inf;
        break;
    }
  }

  range = {lo[n - 1], hi[n - 1]};

  // Caps, floors and dropped operands, top-down (see the proof above).
  auto cap       = std::vector<float>(n, flt_inf);
  auto floor     = std::vector<float>(n, -flt_inf);
  auto reached   = std::vector<char>(n, 0);
  auto pass      = std::vector<int>(n, invalidid);  // n becomes this operand
  reached[n - 1] = 1;
  for (auto i = n - 1; i >= 0; i--) {
    if (!reached[i]) continue;
    auto& node = nodes[i];
    auto  l = node.left, r = node.right;
    auto  k    = std::max(node.blend, 0.0f);
    auto  keep = [&](int operand, float c, float f) {
      reached[operand] = 1;
      cap[operand]     = c;
      floor[operand]   = f;
    };
    // n becomes `operand`, which inherits n's cap and floor.
    auto become = [&](int operand) {
      pass[i] = operand;
      keep(operand, cap[i], floor[i]);
    };
    switch (node.type) {
      IMPLICIT_SDF_PRIMITIVE_CASES break;
      case sdf_type::op_union:
        if (lo[l] >= std::min(cap[i], hi[r])) {
          become(r);
        } else if (lo[r] >= std::min(cap[i], hi[l])) {
          become(l);
        } else {
          keep(l, std::min(cap[i], hi[r]), floor[i]);
          keep(r, std::min(cap[i], hi[l]), floor[i]);
        }
        break;
      case sdf_type::op_intersection:
        if (hi[l] <= std::max(floor[i], lo[r])) {
          become(r);
        } else if (hi[r] <= std::max(floor[i], lo[l])) {
          become(l);
        } else {
          keep(l, cap[i], std::max(floor[i], lo[r]));
          keep(r, cap[i], std::max(floor[i], lo[l]));
        }
        break;
      case sdf_type::op_subtraction:
        if (-lo[r] <= std::max(floor[i], lo[l])) {
          become(l);
        } else {
          keep(l, cap[i], std::max(floor[i], -hi[r]));
          keep(r, -std::max(floor[i], lo[l]), -cap[i]);
        }
        break;
      case sdf_type::op_smooth_union: {
        auto reach_l = smooth_cap(cap[i], lo[r], k);
        auto reach_r = smooth_cap(cap[i], lo[l], k);
        if (lo[l] >= std::min(hi[r] + k, reach_l)) {
          become(r);
        } else if (lo[r] >= std::min(hi[l] + k, reach_r)) {
          become(l);
        } else {
          keep(l, std::min(hi[r] + k, reach_l), -flt_inf);
          keep(r, std::min(hi[l] + k, reach_r), -flt_inf);
        }
        break;
      }
      case sdf_type::op_smooth_intersection: {
        auto reach_l = -smooth_cap(-floor[i], -hi[r], k);
        auto reach_r = -smooth_cap(-floor[i], -hi[l], k);
        if (hi[l] <= std::max(lo[r] - k, reach_l)) {
          become(r);
        } else if (hi[r] <= std::max(lo[l] - k, reach_r)) {
          become(l);
        } else {
          keep(l, flt_inf, std::max(lo[r] - k, reach_l));
          keep(r, flt_inf, std::max(lo[l] - k, reach_r));
        }
        break;
      }
      case sdf_type::op_smooth_subtraction: {
        // The operands are a and c = -b, c in [-hi_b, -lo_b].
        auto reach_l = -smooth_cap(-floor[i], lo[r], k);
        auto reach_c = -smooth_cap(-floor[i], -hi[l], k);
        if (-lo[r] <= std::max(lo[l] - k, reach_c)) {
          become(l);
        } else {
          keep(l, flt_inf, std::max(-hi[r] - k, reach_l));
          keep(r, -std::max(lo[l] - k, reach_c), -flt_inf);
        }
        break;
      }
      case sdf_type::op_round:
        keep(l, cap[i] + node.radius, floor[i] + node.radius);
        break;
      case sdf_type::op_onion: keep(l, flt_inf, -flt_inf); break;
      case sdf_type::op_transform: {
        auto s = program.frame_scales[node.frame];
        if (s > 0) {
          keep(l, cap[i] / s, floor[i] / s);
        } else {
          keep(l, flt_inf, -flt_inf);
        }
        break;
      }
        IMPLICIT_SDF_WARP_CASES
        IMPLICIT_SDF_MATH_CASES
        if (node.left >= 0) keep(node.left, flt_inf, -flt_inf);
        if (node.right >= 0) keep(node.right, flt_inf, -flt_inf);
        break;
    }
  }

  // Emit the kept nodes in their order (operands stay before users), each
  // passed-through node replaced by what it became; a transform of a
  // transform is merged into one map (the child's frame after the parent's)
  // with the product of their distance factors.
  auto target = std::vector<int>(n, invalidid);
  for (auto i = 0; i < n; i++) target[i] = pass[i] >= 0 ? target[pass[i]] : i;
  auto pruned = sdf_program{};
  auto index  = std::vector<int>(n, invalidid);
  for (auto i = 0; i < n; i++) {
    if (!reached[i] || pass[i] >= 0) continue;
    auto node = nodes[i];
    if (node.left >= 0) node.left = index[target[node.left]];
    if (node.right >= 0) node.right = index[target[node.right]];
    if (node.type == sdf_type::op_transform) {
      auto& frame = program.frames[node.frame];
      auto  scale = program.frame_scales[node.frame];
      auto& child = pruned.nodes[node.left];
      if (child.type == sdf_type::op_transform) {
        pruned.frames[child.frame] = pruned.frames[child.frame] * frame;
        pruned.frame_scales[child.frame] *= scale;
        index[i] = node.left;
        continue;
      }
      pruned.frames.push_back(frame);
      pruned.frame_scales.push_back(scale);
      node.frame = (int)pruned.frames.size() - 1;
    }
    index[i] = add_node(pruned, node);
  }
  assert(index[target[n - 1]] == root_node(pruned));
  return pruned;
}

// -----------------------------------------------------------------------------
// UNION PARTS
// -----------------------------------------------------------------------------

// Copy the subtree of `root` into `part` (operands first) and return its new
// root. Explicit stack; the copied nodes keep their relative order.
static int copy_subtree(
    const sdf_program& program, int root, sdf_program& part) {
  auto members = std::vector<int>{};
  auto stack   = std::vector<int>{root};
  while (!stack.empty()) {
    auto index = stack.back();
    stack.pop_back();
    members.push_back(index);
    auto& node = program.nodes[index];
    if (node.left >= 0) stack.push_back(node.left);
    if (node.right >= 0) stack.push_back(node.right);
  }
  std::sort(members.begin(), members.end());
  auto offset = (int)part.nodes.size();
  auto remap  = [&](int index) {
    auto it = std::lower_bound(members.begin(), members.end(), index);
    return offset + (int)(it - members.begin());
  };
  for (auto index : members) {
    auto node = program.nodes[index];
    if (node.left >= 0) node.left = remap(node.left);
    if (node.right >= 0) node.right = remap(node.right);
    if (node.type == sdf_type::op_transform) {
      part.frames.push_back(program.frames[node.frame]);
      part.frame_scales.push_back(program.frame_scales[node.frame]);
      node.frame = (int)part.frames.size() - 1;
    }
    part.nodes.push_back(node);
  }
  return root_node(part);
}

std::vector<sdf_program> split_sdf_union(const sdf_program& program) {
  if (program.nodes.empty()) return {program};
  // Walk down from the root through unions and transforms, composing the
  // transforms' maps (the inner map after the outer) and distance factors.
  struct operand {
    int     node   = invalidid;
    frame3f frame  = {};
    float   scale  = 1;
    bool    mapped = false;
  };
  auto operands = std::vector<operand>{};
  auto stack    = std::vector<operand>{{root_node(program), {}, 1, false}};
  auto unions   = 0;
  while (!stack.empty()) {
    auto item = stack.back();
    stack.pop_back();
    auto& node = program.nodes[item.node];
    if (node.type == sdf_type::op_union) {
      unions++;
      // Right first on the stack, so operands come out left to right.
      auto right = item, left = item;
      right.node = node.right;
      left.node  = node.left;
      stack.push_back(right);
      stack.push_back(left);
    } else if (node.type == sdf_type::op_transform) {
      auto& frame = program.frames[node.frame];
      item.frame  = item.mapped ? frame * item.frame : frame;
      item.scale *= program.frame_scales[node.frame];
      item.mapped = true;
      item.node   = node.left;
      stack.push_back(item);
    } else {
      operands.push_back(item);
    }
  }
  if (unions == 0) return {program};
  // One program per operand, with its merged transform on top.
  auto make_part = [&](const operand& item, sdf_program& part) {
    auto root = copy_subtree(program, item.node, part);
    if (!item.mapped) return root;
    part.frames.push_back(item.frame);
    part.frame_scales.push_back(item.scale);
    auto node  = sdf_node{};
    node.type  = sdf_type::op_transform;
    node.left  = root;
    node.frame = (int)part.frames.size() - 1;
    return add_node(part, node);
  };
  auto parts     = std::vector<sdf_program>{};
  auto rest      = sdf_program{};  // the unbounded operands, one union
  auto unbounded = std::vector<int>{};
  for (auto& item : operands) {
    auto part = sdf_program{};
    make_part(item, part);
    auto box = sdf_bounds(part);
    if (!is_empty(box) && is_finite(box)) {
      parts.push_back(std::move(part));
      continue;
    }
    unbounded.push_back(make_part(item, rest));
  }
  if (!unbounded.empty()) {
    auto op = sdf_node{};
    op.type = sdf_type::op_union;
    fold_sdf_operands(rest, unbounded, op);
    parts.push_back(std::move(rest));
  }
  return parts;
}

}  // namespace implicit
