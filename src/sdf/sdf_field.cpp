// # implicit: fields of simplified tapes (implementation)

#include "sdf_field.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "sdf_primitives.h"

namespace implicit {

// -----------------------------------------------------------------------------
// FIELDS
// -----------------------------------------------------------------------------

// Corner `octant` (bit 0: x, 1: y, 2: z high) of a box split at its centre;
// find_sdf_tape() computes the same midpoints.
static bbox3f octant_box(const bbox3f& box, int octant) {
  auto mid = (box.min + box.max) * 0.5f;
  auto b   = box;
  for (auto a = 0; a < 3; a++) {
    if (octant & (1 << a)) {
      at(b.min, a) = at(mid, a);
    } else {
      at(b.max, a) = at(mid, a);
    }
  }
  return b;
}

// Octree depth for a program with `leaves` primitives: about one cell per
// primitive, cbrt(leaves) per axis (cells near the surface only are split
// that far: the others prune to a few nodes, or a constant, and stop), plus
// `extra` levels, at most 9.
static int field_depth(size_t leaves, int extra) {
  auto cells = std::cbrt(std::max(1.0, (double)leaves));
  return std::clamp((int)std::ceil(std::log2(cells)) + extra, 1, 9);
}

// Build the octree of `field` down to `max_depth`, its leaf clauses within
// about `max_bytes`.
static void build_octree(sdf_field& field, const sdf_field_params& params,
    int max_depth, size_t max_bytes) {
  // Depth first with an explicit stack, so that only the tapes along one
  // path (8 per level) are held at a time; the 8 children of a cell share
  // their parent's simplified tape and its budget: each child may use what
  // its earlier siblings left, divided among it and the later ones (a cell
  // that would not fit stays a leaf, with its larger tape).
  struct group {
    size_t budget = 0;  // bytes for the 8 children's leaves
    size_t start  = 0;  // bytes stored before the first child
  };
  using clause_list = std::vector<sdf_ssa>;
  struct pending {
    int                                cell     = 0;
    bbox3f                             box      = {};
    int                                depth    = 0;
    int                                octant   = 0;
    std::shared_ptr<const clause_list> ssa      = nullptr;
    std::shared_ptr<const group>       siblings = nullptr;
  };
  auto state  = sdf_simplify_state{};
  auto stored = size_t{0};  // bytes of the leaf clauses
  auto stack  = std::vector<pending>{
       {0, field.box, 0, 0, std::make_shared<const clause_list>(field.full.ssa),
           std::make_shared<const group>(group{max_bytes * 8, 0})}};
  field.cells.push_back({});
  while (!stack.empty()) {
    auto item = std::move(stack.back());
    stack.pop_back();
    auto used = stored - item.siblings->start;
    auto left =
        item.siblings->budget > used ? item.siblings->budget - used : size_t{0};
    auto budget     = left / (8 - item.octant);
    auto simplified = clause_list{};
    auto range =
        simplify_sdf(field.full, *item.ssa, item.box, state, simplified);
    auto  size  = simplified.size();
    auto& cell  = field.cells[item.cell];
    cell.range  = range;
    field.depth = std::max(field.depth, item.depth);
    // Far from the surface: a constant bound (see sdf_cell).
    auto far = length(item.box.max - item.box.min) * 0.25f;
    if (range.lo >= far || range.hi <= -far) {
      cell.bound = range.lo > 0 ? range.lo : range.hi;
      continue;
    }
    // A leaf when small enough, deep enough, when its children would not
    // fit its budget (they hold about 3 times its clauses: operands near
    // their boundaries are in several), or when simplification stopped
    // working (a chain of roundings has nothing to drop: its cells would
    // multiply copies of it).
    auto leaf = (int)size <= params.leaf_nodes || item.depth >= max_depth ||
                3 * size * sizeof(sdf_clause) > budget ||
                (item.depth >= 3 && size >= item.ssa->size());
    if (leaf) {
      auto begin = field.clauses.size();
      allocate_sdf_registers(simplified, field.clauses);
      cell.begin = (int)begin;
      cell.count = (int)(field.clauses.size() - begin);
      // A distance program keeps its global bound; others get the bound of
      // their cell's gradient (interval derivatives of the cell's tape).
      cell.lipschitz =
          field.distance
              ? field.full.lipschitz
              : eval_sdf_lipschitz(field.full,
                    field.clauses.data() + cell.begin,
                    field.clauses.data() + field.clauses.size(), item.box);
      stored += (size_t)cell.count * sizeof(sdf_clause);
      continue;
    }
    auto children = (int)field.cells.size();
    cell.children = children;
    field.cells.resize(field.cells.size() + 8);
    auto shared   = std::make_shared<const clause_list>(std::move(simplified));
    auto siblings = std::make_shared<const group>(group{budget, stored});
    for (auto octant = 7; octant >= 0; octant--)
      stack.push_back({children + octant, octant_box(item.box, octant),
          item.depth + 1, octant, shared, siblings});
  }
}

// Default budget of the leaf steps: 4 KiB per node of the program, at least
// 32 MiB and at most 1 GiB.
static constexpr size_t field_min_bytes = size_t{32} << 20;
static constexpr size_t field_max_bytes = size_t{1} << 30;

sdf_field make_sdf_field(const sdf_program& program, const bbox3f& box,
    const sdf_field_params& params) {
  auto field      = sdf_field{};
  field.full      = make_sdf_tape(program);
  field.distance  = std::isfinite(field.full.lipschitz);
  auto count      = program.nodes.size();
  auto primitives = size_t{0};
  for (auto& node : program.nodes) primitives += is_primitive(node.type);
  // Expressions have few primitives or none: their operands are counted as
  // about one per 16 math clauses (a circle or a capsule of the Prospero
  // model is 8 to 20), and functions that are no distance bound go 2 levels
  // deeper: their tracer steps by the bounds of the cells (smaller cells,
  // tighter bounds, shorter tapes to bound). An 8,000-clause text slab at
  // 240 px, 1 spp: depth 4 (as CSG) 3.6 s, 5: 2.0 s, 6: 1.5 s, 7: 1.5 s.
  primitives = std::max(primitives, count / 16);
  if ((int)count <= params.leaf_nodes || is_empty(box) || !is_finite(box))
    return field;
  // Cubic cells (a flat object would get flat cells, split for nothing
  // along its thin axis): the root is the box grown to a cube.
  auto half      = max(box.max - box.min) * 0.5f;
  field.box      = {center(box) - half, center(box) + half};
  auto max_depth = params.max_depth >= 0
                       ? params.max_depth
                       : field_depth(primitives, field.distance ? 1 : 3);
  auto max_bytes = params.max_bytes > 0 ? params.max_bytes
                                        : std::clamp(count * 16384,
                                              field_min_bytes, field_max_bytes);
  build_octree(field, params, max_depth, max_bytes);
  return field;
}

int find_sdf_cell(const sdf_field& field, vec3f p, bbox3f& box) {
  if (field.cells.empty() || !inside(field.box, p)) return invalidid;
  auto cell = 0;
  box       = field.box;
  while (field.cells[cell].children >= 0) {
    auto mid    = (box.min + box.max) * 0.5f;
    auto octant = (p.x >= mid.x ? 1 : 0) | (p.y >= mid.y ? 2 : 0) |
                  (p.z >= mid.z ? 4 : 0);
    box  = octant_box(box, octant);
    cell = field.cells[cell].children + octant;
  }
  return cell;
}

int find_sdf_cell(const sdf_field& field, vec3f p) {
  auto box = bbox3f{};
  return find_sdf_cell(field, p, box);
}

interval eval_sdf_cell_interval(
    const sdf_field& field, int cell, const bbox3f& box) {
  if (cell < 0) return eval_sdf_interval(field.full, box);
  auto& leaf = field.cells[cell];
  if (leaf.count == 0) return leaf.range;
  auto begin = field.clauses.data() + leaf.begin;
  return eval_sdf_interval(field.full, begin, begin + leaf.count, box);
}

vec3f eval_sdf_gradient(const sdf_field& field, vec3f p, float step) {
  // One primitive in the object's space: its analytic gradient, or its own
  // finite differences.
  auto cell  = find_sdf_cell(field, p);
  auto shape = sdf_node{};
  if (cell >= 0 && field.cells[cell].count > 0) {
    auto begin = field.clauses.data() + field.cells[cell].begin;
    if (is_single_shape(
            field.full, begin, begin + field.cells[cell].count, shape)) {
      auto g = vec3f{};
      if (eval_primitive_gradient(shape, p, g)) return g;
      return normalize(tetrahedral_gradient(
          [&](vec3f q) { return eval_primitive(shape, q); }, p, step));
    }
  }
  if (cell < 0 && field.cells.empty())
    return eval_sdf_gradient(field.full, p, step);
  return normalize(tetrahedral_gradient(
      [&](vec3f q) { return eval_sdf(field, q); }, p, step));
}

size_t sdf_field_bytes(const sdf_field& field) {
  return sizeof(field) + field.cells.size() * sizeof(sdf_cell) +
         sdf_tape_bytes(field.full) + field.clauses.size() * sizeof(sdf_clause);
}

}  // namespace implicit
