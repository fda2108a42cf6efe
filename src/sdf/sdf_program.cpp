// # implicit: SDF programs (implementation)

#include "sdf_program.h"

#include <cassert>

#include "sdf_primitives.h"

namespace implicit {

// -----------------------------------------------------------------------------
// BUILDING
// -----------------------------------------------------------------------------

int add_node(sdf_program& program, const sdf_node& node) {
  program.nodes.push_back(node);
  return root_node(program);
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

float eval_primitive(const sdf_node& node, vec3f p) {
  switch (node.type) {
    case sdf_type::box: return sd_box(p, node.size);
    case sdf_type::bbox: return sd_box_frame(p, node.size, node.thickness);
    case sdf_type::sphere: return sd_sphere(p, node.radius);
    case sdf_type::torus: return sd_torus(p, node.radius, node.radius2);
    case sdf_type::capped_cone:
      return sd_capped_cone(p, node.height, node.radius, node.radius2);
    case sdf_type::plane: return sd_plane(p);
    case sdf_type::capsule: return sd_capsule(p, node.height, node.radius);
    case sdf_type::cylinder: return sd_cylinder(p, node.height, node.radius);
    case sdf_type::rounded_box:
      return sd_rounded_box(p, node.size, node.radius);
    case sdf_type::ellipsoid: return sd_ellipsoid(p, node.size);
    case sdf_type::octahedron: return sd_octahedron(p, node.radius);
    case sdf_type::op_union:
    case sdf_type::op_intersection:
    case sdf_type::op_subtraction:
    case sdf_type::op_smooth_union:
    case sdf_type::op_smooth_intersection:
    case sdf_type::op_smooth_subtraction:
    case sdf_type::op_round:
    case sdf_type::op_onion:
    case sdf_type::op_transform: break;
  }
  assert(false && "eval_primitive on an operator");
  return flt_max;
}

// Recursive evaluation of node `index`; depth is bounded by the tree depth.
static float eval_node(const sdf_program& program, int index, vec3f p) {
  auto& node = program.nodes[index];
  switch (node.type) {
    case sdf_type::op_union:
      return std::min(
          eval_node(program, node.left, p), eval_node(program, node.right, p));
    case sdf_type::op_intersection:
      return std::max(
          eval_node(program, node.left, p), eval_node(program, node.right, p));
    case sdf_type::op_subtraction:
      return std::max(
          eval_node(program, node.left, p), -eval_node(program, node.right, p));
    case sdf_type::op_smooth_union:
      return smooth_min(eval_node(program, node.left, p),
          eval_node(program, node.right, p), node.blend);
    case sdf_type::op_smooth_intersection:
      return smooth_max(eval_node(program, node.left, p),
          eval_node(program, node.right, p), node.blend);
    case sdf_type::op_smooth_subtraction:
      return smooth_max(eval_node(program, node.left, p),
          -eval_node(program, node.right, p), node.blend);
    case sdf_type::op_round:
      return eval_node(program, node.left, p) - node.radius;
    case sdf_type::op_onion:
      return std::abs(eval_node(program, node.left, p)) - node.thickness;
    case sdf_type::op_transform:
      return eval_node(program, node.left,
                 transform_point(program.frames[node.frame], p)) *
             program.frame_scales[node.frame];
    default: return eval_primitive(node, p);
  }
}

float eval_sdf(const sdf_program& program, vec3f p) {
  assert(!program.nodes.empty());
  auto& root = program.nodes.back();
  if (is_primitive(root.type)) return eval_primitive(root, p);
  return eval_node(program, root_node(program), p);
}

// Analytic gradient where it is cheap and exact; returns false otherwise.
static bool eval_primitive_gradient(const sdf_node& node, vec3f p, vec3f& g) {
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
    default: return false;
  }
}

vec3f eval_sdf_gradient(const sdf_program& program, vec3f p, float step) {
  auto& root = program.nodes.back();
  auto  g    = vec3f{};
  if (is_primitive(root.type) && eval_primitive_gradient(root, p, g)) return g;
  // Tetrahedral central differences (IQ, "normals for an SDF"): four
  // evaluations instead of six.
  auto k0 = vec3f{1, -1, -1}, k1 = vec3f{-1, -1, 1}, k2 = vec3f{-1, 1, -1},
       k3 = vec3f{1, 1, 1};
  g       = k0 * eval_sdf(program, p + k0 * step) +
      k1 * eval_sdf(program, p + k1 * step) +
      k2 * eval_sdf(program, p + k2 * step) +
      k3 * eval_sdf(program, p + k3 * step);
  return normalize(g);
}

// -----------------------------------------------------------------------------
// BOUNDS AND LIPSCHITZ
// -----------------------------------------------------------------------------

static bbox3f primitive_bounds(const sdf_node& node) {
  auto centered = [](vec3f half) { return bbox3f{-half, half}; };
  switch (node.type) {
    case sdf_type::box: return {{0, 0, 0}, node.size};
    case sdf_type::bbox: return centered(node.size);
    case sdf_type::sphere: return centered(vec3f{1, 1, 1} * node.radius);
    case sdf_type::torus: {
      auto r = node.radius + node.radius2;
      return centered({r, node.radius2, r});
    }
    case sdf_type::capped_cone: {
      auto r = std::max(node.radius, node.radius2);
      return centered({r, node.height, r});
    }
    case sdf_type::plane:
      return {{-flt_inf, 0, -flt_inf}, {flt_inf, 0, flt_inf}};
    case sdf_type::capsule:
      return centered({node.radius, node.height + node.radius, node.radius});
    case sdf_type::cylinder:
      return centered({node.radius, node.height, node.radius});
    case sdf_type::rounded_box: return centered(node.size);
    case sdf_type::ellipsoid: return centered(node.size);
    case sdf_type::octahedron: return centered(vec3f{1, 1, 1} * node.radius);
    default: return {};
  }
}

static bbox3f node_bounds(const sdf_program& program, int index) {
  auto& node = program.nodes[index];
  switch (node.type) {
    case sdf_type::op_union:
      return merge(
          node_bounds(program, node.left), node_bounds(program, node.right));
    case sdf_type::op_intersection:
      return intersect(
          node_bounds(program, node.left), node_bounds(program, node.right));
    case sdf_type::op_subtraction: return node_bounds(program, node.left);
    // The smooth minimum lies at most blend/4 below the minimum, so a
    // smooth union grows by that much; the smooth maximum is never below the
    // maximum, so smooth intersections and subtractions do not grow.
    case sdf_type::op_smooth_union:
      return expand(merge(node_bounds(program, node.left),
                        node_bounds(program, node.right)),
          node.blend * 0.25f);
    case sdf_type::op_smooth_intersection:
      return intersect(
          node_bounds(program, node.left), node_bounds(program, node.right));
    case sdf_type::op_smooth_subtraction:
      return node_bounds(program, node.left);
    case sdf_type::op_round:
      return expand(node_bounds(program, node.left), node.radius);
    case sdf_type::op_onion:
      return expand(node_bounds(program, node.left), node.thickness);
    case sdf_type::op_transform:
      return transform_bbox(
          inverse(program.frames[node.frame]), node_bounds(program, node.left));
    default: return primitive_bounds(node);
  }
}

bbox3f sdf_bounds(const sdf_program& program) {
  if (program.nodes.empty()) return {};
  return node_bounds(program, root_node(program));
}

static float node_lipschitz(const sdf_program& program, int index) {
  auto& node = program.nodes[index];
  switch (node.type) {
    case sdf_type::ellipsoid: {
      // IQ's bound k0(k0-1)/k1 is steeper than 1 away from the surface by at
      // most the axis ratio.
      auto lo = min(node.size), hi = max(node.size);
      return lo > 0 ? hi / lo : 1;
    }
    case sdf_type::op_union:
    case sdf_type::op_intersection:
    case sdf_type::op_subtraction:
    case sdf_type::op_smooth_union:
    case sdf_type::op_smooth_intersection:
    case sdf_type::op_smooth_subtraction:
      return std::max(node_lipschitz(program, node.left),
          node_lipschitz(program, node.right));
    case sdf_type::op_round:
    case sdf_type::op_onion:
    case sdf_type::op_transform: return node_lipschitz(program, node.left);
    default: return 1;
  }
}

float sdf_lipschitz(const sdf_program& program) {
  if (program.nodes.empty()) return 1;
  return node_lipschitz(program, root_node(program));
}

// -----------------------------------------------------------------------------
// EXACT INTERSECTIONS
// -----------------------------------------------------------------------------

bool has_exact_intersection(const sdf_program& program) {
  if (program.nodes.size() != 1) return false;
  auto type = program.nodes[0].type;
  return type == sdf_type::sphere || type == sdf_type::box ||
         type == sdf_type::plane;
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
    const sdf_program& program, const ray3f& ray, bool& hit, float& t) {
  if (!has_exact_intersection(program)) return false;
  auto& node = program.nodes[0];
  hit        = false;
  switch (node.type) {
    case sdf_type::sphere: {
      // Quadratic in t; the ray direction need not be unit length.
      auto a = dot(ray.d, ray.d);
      auto b = dot(ray.o, ray.d);
      auto c = dot(ray.o, ray.o) - node.radius * node.radius;
      // Stable discriminant (Hearn & Baker form used by pbrt/RT Gems ch. 7).
      auto l    = ray.o - ray.d * (b / a);
      auto disc = node.radius * node.radius - dot(l, l);
      if (disc < 0) return true;
      auto q  = -b - std::copysign(std::sqrt(a * disc), b);
      auto t0 = c / q, t1 = q / a;
      if (q == 0) t0 = t1 = -b / a;
      if (t0 > t1) std::swap(t0, t1);
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
    default: return false;
  }
}

}  // namespace implicit
