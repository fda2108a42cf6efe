// # implicit: SDF programs (implementation)

#include "sdf_program.h"

#include <algorithm>
#include <cassert>
#include <string>
#include <utility>

#include "../util/error.h"
#include "sdf_primitives.h"

namespace implicit {

// -----------------------------------------------------------------------------
// BUILDING
// -----------------------------------------------------------------------------

int add_node(sdf_program& program, const sdf_node& node) {
  program.nodes.push_back(node);
  return root_node(program);
}

int fold_sdf_operands(
    sdf_program& program, const std::vector<int>& operands, sdf_node op) {
  if (operands.empty()) return invalidid;
  auto combine = [&](int left, int right) {
    op.left  = left;
    op.right = right;
    return add_node(program, op);
  };
  if (op.type != sdf_type::op_smooth_union &&
      op.type != sdf_type::op_smooth_intersection) {
    auto root = operands[0];
    for (size_t i = 1; i < operands.size(); i++)
      root = combine(root, operands[i]);
    return root;
  }
  auto level = operands;
  while (level.size() > 1) {
    auto next = std::vector<int>{};
    next.reserve((level.size() + 1) / 2);
    for (size_t i = 0; i + 1 < level.size(); i += 2)
      next.push_back(combine(level[i], level[i + 1]));
    if (level.size() % 2 == 1) next.push_back(level.back());
    level = std::move(next);
  }
  return level[0];
}

std::vector<char> find_smooth_groups(const sdf_program& program) {
  auto n     = (int)program.nodes.size();
  auto users = std::vector<int>(n, 0);
  for (auto& node : program.nodes) {
    auto count = sdf_operand_count(node.type);
    if (count >= 1) users[node.left]++;
    if (count >= 2) users[node.right]++;
  }
  auto absorbed = std::vector<char>(n, 0);
  for (auto& node : program.nodes) {
    if (node.type != sdf_type::op_smooth_union) continue;
    for (auto operand : {node.left, node.right}) {
      auto& child = program.nodes[operand];
      if (child.type == sdf_type::op_smooth_union && users[operand] == 1 &&
          child.blend == node.blend)
        absorbed[operand] = 1;
    }
  }
  return absorbed;
}

void smooth_group_operands(const sdf_program& program,
    const std::vector<char>& absorbed, int root, std::vector<int>& operands) {
  operands.clear();
  auto stack = std::vector<int>{root};
  while (!stack.empty()) {
    auto index = stack.back();
    stack.pop_back();
    if (index != root && !absorbed[index]) {
      operands.push_back(index);
      continue;
    }
    auto& node = program.nodes[index];
    stack.push_back(node.right);
    stack.push_back(node.left);
  }
}

int add_transform(
    sdf_program& program, int operand, const frame3f& child_from_parent) {
  program.frames.push_back(child_from_parent);
  // A map that stretches by s makes the child s-Lipschitz in the parent's
  // space; dividing by s restores a distance bound (exact for rigid maps).
  auto stretch = max_stretch(child_from_parent);
  program.frame_scales.push_back(stretch > 0 ? 1 / stretch : 0);
  auto node  = sdf_node{};
  node.type  = sdf_type::op_transform;
  node.left  = operand;
  node.frame = (int)program.frames.size() - 1;
  return add_node(program, node);
}

int append_program(sdf_program& program, const sdf_program& other) {
  auto node_offset  = (int)program.nodes.size();
  auto frame_offset = (int)program.frames.size();
  for (auto node : other.nodes) {
    if (node.left != invalidid) node.left += node_offset;
    if (node.right != invalidid) node.right += node_offset;
    if (node.frame != invalidid) node.frame += frame_offset;
    program.nodes.push_back(node);
  }
  program.frames.insert(
      program.frames.end(), other.frames.begin(), other.frames.end());
  program.frame_scales.insert(program.frame_scales.end(),
      other.frame_scales.begin(), other.frame_scales.end());
  return root_node(program);
}

sdf_program make_primitive_program(const sdf_node& node) {
  auto program = sdf_program{};
  add_node(program, node);
  return program;
}

// -----------------------------------------------------------------------------
// EVALUATION
// -----------------------------------------------------------------------------

int sdf_operand_count(sdf_type type) {
  switch (type) {
    IMPLICIT_SDF_PRIMITIVE_CASES return 0;
    case sdf_type::op_round:
    case sdf_type::op_onion:
    case sdf_type::op_transform: return 1;
    case sdf_type::op_union:
    case sdf_type::op_intersection:
    case sdf_type::op_subtraction:
    case sdf_type::op_smooth_union:
    case sdf_type::op_smooth_intersection:
    case sdf_type::op_smooth_subtraction:
      return 2;
      IMPLICIT_SDF_WARP_CASES return 1;
#define IMPLICIT_SDF_MATH_OPERANDS(id, name, operands) \
  case sdf_type::id: return operands;
      IMPLICIT_SDF_MATH(IMPLICIT_SDF_MATH_OPERANDS)
#undef IMPLICIT_SDF_MATH_OPERANDS
  }
  return 0;
}

bool eval_primitive_gradient(const sdf_node& node, vec3f p, vec3f& g) {
  switch (node.type) {
    case sdf_type::sphere: g = normalize(p); return length_squared(p) > 0;
    case sdf_type::plane: g = {0, 1, 0}; return true;
    case sdf_type::box: {
      // Outside: direction to the closest point; inside: the nearest face.
      // Thin boxes (the seed's floor and lights are 1e-5 thick) need this:
      // finite differences wider than the box cancel out.
      auto half = node.size * 0.5f;
      auto q    = p - half;
      auto d    = abs(q) - half;
      if (max(d) > 0) {
        auto outside = max(d, 0.0f);
        g            = normalize(vec3f{std::copysign(outside.x, q.x),
            std::copysign(outside.y, q.y), std::copysign(outside.z, q.z)});
      } else {
        auto axis   = (d.x > d.y && d.x > d.z) ? 0 : (d.y > d.z ? 1 : 2);
        g           = {0, 0, 0};
        at(g, axis) = sign(at(q, axis));
      }
      return true;
    }
    case sdf_type::torus: {
      auto r = length(vec2f{p.x, p.z});
      if (r == 0) return false;
      auto c = vec3f{p.x / r * node.radius, 0, p.z / r * node.radius};
      g      = normalize(p - c);
      return true;
    }
    case sdf_type::bbox:
    case sdf_type::capped_cone:
    case sdf_type::capsule:
    case sdf_type::cylinder:
    case sdf_type::rounded_box:
    case sdf_type::ellipsoid:
    case sdf_type::octahedron: IMPLICIT_SDF_OPERATOR_CASES return false;
  }
  return false;
}

// -----------------------------------------------------------------------------
// BOUNDS AND LIPSCHITZ
// -----------------------------------------------------------------------------

bbox3f primitive_bounds(const sdf_node& node) {
#define IMPLICIT_SDF_BOUNDS(id, name) \
  case sdf_type::id: return bounds_##id(node);
  switch (node.type) {
    IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_BOUNDS)
    IMPLICIT_SDF_OPERATOR_CASES break;
  }
#undef IMPLICIT_SDF_BOUNDS
  assert(false && "primitive_bounds on an operator");
  return {};
}

float primitive_lipschitz(const sdf_node& node) {
#define IMPLICIT_SDF_LIPSCHITZ(id, name) \
  case sdf_type::id: return lipschitz_##id(node);
  switch (node.type) {
    IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_LIPSCHITZ)
    IMPLICIT_SDF_OPERATOR_CASES break;
  }
#undef IMPLICIT_SDF_LIPSCHITZ
  assert(false && "primitive_lipschitz on an operator");
  return 1;
}

sdf_param_list primitive_params(sdf_type type) {
#define IMPLICIT_SDF_PARAMS(id, name) \
  case sdf_type::id: return make_param_list(sdf_params_##id);
  switch (type) {
    IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_PARAMS)
    IMPLICIT_SDF_OPERATOR_CASES break;
  }
#undef IMPLICIT_SDF_PARAMS
  return {};
}

sdf_param_problem check_primitive(const sdf_node& node) {
#define IMPLICIT_SDF_CHECK(id, name) \
  case sdf_type::id: return check_##id(node);
  switch (node.type) {
    IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_CHECK)
    IMPLICIT_SDF_OPERATOR_CASES break;
  }
#undef IMPLICIT_SDF_CHECK
  return {};
}

// Box of the points a domain operator maps into `box` (its operand's box):
// twist and bend keep the distance to their axis, repeat places copies up
// to `count` periods away (infinitely many when count < 0), elongate moves
// points by at most the extent, mirror reflects.
static bbox3f warp_bounds(const sdf_node& node, const bbox3f& box) {
  auto extent = [](float lo, float hi) { return std::max(lo * lo, hi * hi); };
  auto result = box;
  switch (node.type) {
    case sdf_type::op_twist: {
      auto r = std::sqrt(
          extent(box.min.x, box.max.x) + extent(box.min.z, box.max.z));
      result.min.x = result.min.z = -r;
      result.max.x = result.max.z = r;
      break;
    }
    case sdf_type::op_bend: {
      auto r = std::sqrt(
          extent(box.min.x, box.max.x) + extent(box.min.y, box.max.y));
      result.min.x = result.min.y = -r;
      result.max.x = result.max.y = r;
      break;
    }
    case sdf_type::op_repeat:
      for (auto a = 0; a < 3; a++) {
        auto size  = at(node.size, a);
        auto count = a == 0   ? node.count.x
                     : a == 1 ? node.count.y
                              : node.count.z;
        if (!(size > 0)) continue;
        auto reach = count < 0 ? flt_inf : size * (float)count;
        at(result.min, a) -= reach;
        at(result.max, a) += reach;
      }
      break;
    case sdf_type::op_elongate:
      result = {box.min - node.size, box.max + node.size};
      break;
    case sdf_type::op_mirror:
      for (auto a = 0; a < 3; a++) {
        if (!(node.axes & (1 << a))) continue;
        at(result.min, a) = -at(box.max, a);
      }
      break;
      IMPLICIT_SDF_PRIMITIVE_CASES
      IMPLICIT_SDF_CSG_CASES
      IMPLICIT_SDF_MATH_CASES break;
  }
  return result;
}

// One forward pass over the nodes (operands come first), no recursion.
//
// A smooth union lies below the minimum of its operands by at most
// depth = k h^2 / 4 (h = max(k - |a - b|, 0) / k), so its box is the merged
// boxes of its operands grown by that. Nested smooth unions keep the merged
// box unexpanded (`cores`) and the depth: if the operands lie at most d_a
// and d_b below the minimum m of their own operands, the smooth minimum,
// monotone in each operand, is at least smooth_min(m - d_a, m - d_b), which
// lies below m by max(d_a, d_b) + k h^2 / 4 with h from |d_a - d_b|. A
// group (find_smooth_groups) folds its sorted operands the same way: its
// depth is the fold of m - d_j, which stays below k plus the deepest d_j
// however many operands it has.
bbox3f sdf_bounds(const sdf_program& program) {
  if (program.nodes.empty()) return {};
  return sdf_node_bounds(program).back();
}

std::vector<bbox3f> sdf_node_bounds(const sdf_program& program) {
  auto bounds   = std::vector<bbox3f>(program.nodes.size());
  auto cores    = std::vector<bbox3f>(program.nodes.size());
  auto depths   = std::vector<float>(program.nodes.size(), 0);
  auto absorbed = find_smooth_groups(program);
  auto operands = std::vector<int>{};
  for (auto i = 0; i < (int)program.nodes.size(); i++) {
    auto& node = program.nodes[i];
    auto  left = [&] { return bounds[node.left]; };
    auto  both = [&] { return merge(bounds[node.left], bounds[node.right]); };
    auto  meet = [&] {
      return intersect(bounds[node.left], bounds[node.right]);
    };
    auto& box = bounds[i];
    switch (node.type) {
      case sdf_type::op_union: box = both(); break;
      case sdf_type::op_intersection: box = meet(); break;
      case sdf_type::op_subtraction: box = left(); break;
      // The smooth minimum lies at most blend/4 below the minimum, so a
      // smooth union grows by that much; the smooth maximum is never below
      // the maximum, so smooth intersections and subtractions do not grow.
      case sdf_type::op_smooth_union: {
        if (absorbed[i]) break;  // its group's root bounds it
        smooth_group_operands(program, absorbed, i, operands);
        auto core = [&](int k) { return depths[k] > 0 ? cores[k] : bounds[k]; };
        // The group's value at least that of operands at m - d_j: the
        // sorted fold of the deepest d_j, negated.
        auto lows = std::vector<float>{};
        for (auto k : operands) {
          cores[i] = merge(cores[i], core(k));
          lows.push_back(-depths[k]);
        }
        std::sort(lows.begin(), lows.end());
        auto count = std::min((int)lows.size(), sdf_smooth_group_size);
        depths[i] =
            -smooth_min_sorted(lows.data(), count, std::max(node.blend, 0.0f));
        box = expand(cores[i], depths[i]);
        break;
      }
      case sdf_type::op_smooth_intersection: box = meet(); break;
      case sdf_type::op_smooth_subtraction: box = left(); break;
      case sdf_type::op_round: box = expand(left(), node.radius); break;
      case sdf_type::op_onion: box = expand(left(), node.thickness); break;
      case sdf_type::op_transform:
        box = transform_bbox(inverse(program.frames[node.frame]), left());
        break;
        IMPLICIT_SDF_PRIMITIVE_CASES box = primitive_bounds(node);
        break;
        IMPLICIT_SDF_WARP_CASES box = warp_bounds(node, left());
        break;
        // Expressions have no box of their own (the scene gives one, or
        // the tracer finds it by subdivision): infinite.
        IMPLICIT_SDF_MATH_CASES box = {
            {-flt_inf, -flt_inf, -flt_inf}, {flt_inf, flt_inf, flt_inf}};
        break;
    }
  }
  return bounds;
}

// Whether a node keeps a distance bound a distance bound: primitives, CSG
// operators and the 1-Lipschitz domain maps (|q(p) - q(p')| <= |p - p'|).
static bool is_distance_node(const sdf_node& node) {
  switch (node.type) {
    IMPLICIT_SDF_PRIMITIVE_CASES
    IMPLICIT_SDF_CSG_CASES
    case sdf_type::op_elongate:
    case sdf_type::op_mirror: return true;
    case sdf_type::op_twist:
    case sdf_type::op_bend:
    case sdf_type::op_repeat: IMPLICIT_SDF_MATH_CASES return false;
  }
  return false;
}

// One forward pass, as sdf_bounds().
float sdf_lipschitz(const sdf_program& program) {
  if (program.nodes.empty()) return 1;
  auto lipschitz = std::vector<float>(program.nodes.size(), 1);
  for (auto i = 0; i < (int)program.nodes.size(); i++) {
    auto& node  = program.nodes[i];
    auto  count = sdf_operand_count(node.type);
    if (!is_distance_node(node)) {
      lipschitz[i] = flt_inf;
    } else if (count == 0) {
      lipschitz[i] = primitive_lipschitz(node);
    } else if (count == 1) {
      lipschitz[i] = lipschitz[node.left];
    } else {
      lipschitz[i] = std::max(lipschitz[node.left], lipschitz[node.right]);
    }
  }
  return lipschitz.back();
}

// -----------------------------------------------------------------------------
// EXACT INTERSECTIONS
// -----------------------------------------------------------------------------

bool has_exact_intersection(const sdf_program& program) {
  if (program.nodes.size() != 1) return false;
  auto type = program.nodes[0].type;
  return type == sdf_type::sphere || type == sdf_type::box ||
         type == sdf_type::plane || type == sdf_type::capped_cone;
}

// First of the two roots t0 <= t1 that lies in [tmin, tmax].
static bool first_root(float t0, float t1, const ray3f& ray, float& t) {
  if (t0 >= ray.tmin && t0 <= ray.tmax) {
    t = t0;
    return true;
  }
  if (t1 >= ray.tmin && t1 <= ray.tmax) {
    t = t1;
    return true;
  }
  return false;
}

bool intersect_sdf_exact(
    const sdf_node& node, const ray3f& ray, bool& hit, float& t) {
  hit = false;
  switch (node.type) {
    case sdf_type::sphere: {
      auto t0 = 0.0f, t1 = 0.0f;
      if (!intersect_sphere(ray, node.radius, t0, t1)) return true;
      hit = first_root(t0, t1, ray, t);
      return true;
    }
    case sdf_type::box: {
      auto box = bbox3f{{0, 0, 0}, node.size};
      auto t0 = 0.0f, t1 = 0.0f;
      auto unclipped = ray3f{ray.o, ray.d, flt_min, flt_max};
      if (!intersect_bbox(unclipped, box, t0, t1)) return true;
      hit = first_root(t0, t1, ray, t);
      return true;
    }
    case sdf_type::plane: {
      if (ray.d.y == 0) return true;
      auto tp = -ray.o.y / ray.d.y;
      hit     = tp >= ray.tmin && tp <= ray.tmax;
      if (hit) t = tp;
      return true;
    }
    case sdf_type::capped_cone: {
      float crossings[4];
      auto  count = intersect_capped_cone(
           ray, node.height, node.radius, node.radius2, crossings);
      for (auto i = 0; i < count && !hit; i++) {
        hit = crossings[i] >= ray.tmin && crossings[i] <= ray.tmax;
        if (hit) t = crossings[i];
      }
      return true;
    }
    case sdf_type::bbox:
    case sdf_type::torus:
    case sdf_type::capsule:
    case sdf_type::cylinder:
    case sdf_type::rounded_box:
    case sdf_type::ellipsoid:
    case sdf_type::octahedron: IMPLICIT_SDF_OPERATOR_CASES return false;
  }
  return false;
}

}  // namespace implicit
