// # implicit: octree fields of pruned SDF programs (implementation)

#include <algorithm>
#include <cmath>
#include <memory>

#include "sdf_primitives.h"
#include "sdf_prune.h"

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

// Build the octree of `field` down to `max_depth`, its leaf steps within
// about `max_bytes`.
static void build_octree(sdf_field& field, const sdf_program& program,
    const sdf_field_params& params, int max_depth, size_t max_bytes) {
  // Depth first with an explicit stack, so that only the programs along one
  // path (8 per level) are held at a time; the 8 children of a cell share
  // their parent's pruned program and its budget: each child may use what
  // its earlier siblings left, divided among it and the later ones (a cell
  // that would not fit stays a leaf, with its larger program).
  struct group {
    size_t budget = 0;  // bytes for the 8 children's leaves
    size_t start  = 0;  // bytes stored before the first child
  };
  struct pending {
    int                                cell     = 0;
    bbox3f                             box      = {};
    int                                depth    = 0;
    int                                octant   = 0;
    std::shared_ptr<const sdf_program> program  = nullptr;
    std::shared_ptr<const group>       siblings = nullptr;
  };
  // Pruned copies name their node in the whole program (sdf_node::origin),
  // whose tape holds the nodes and maps for all leaves.
  auto root = program;
  for (auto i = 0; i < (int)root.nodes.size(); i++) root.nodes[i].origin = i;
  auto stored = size_t{0};  // bytes of the leaf steps
  auto stack  = std::vector<pending>{
       {0, field.box, 0, 0, std::make_shared<const sdf_program>(std::move(root)),
           std::make_shared<const group>(group{max_bytes * 8, 0})}};
  field.cells.push_back({});
  while (!stack.empty()) {
    auto item = std::move(stack.back());
    stack.pop_back();
    auto used = stored - item.siblings->start;
    auto left =
        item.siblings->budget > used ? item.siblings->budget - used : size_t{0};
    auto budget = left / (8 - item.octant);
    auto range  = vec2f{};
    auto pruned = prune_sdf(*item.program, item.box, range);
    auto size   = pruned.nodes.size();
    field.depth = std::max(field.depth, item.depth);
    // Far from the surface: a constant bound (see sdf_cell).
    auto far = length(item.box.max - item.box.min) * 0.25f;
    if (range.x >= far || range.y <= -far) {
      field.cells[item.cell].bound = range.x > 0 ? range.x : range.y;
      continue;
    }
    // A leaf when small enough, deep enough, when its children would not
    // fit its budget (they hold about 3 times its steps: operands near
    // their boundaries are in several), or when pruning stopped working (a
    // chain of roundings has nothing to drop: its cells would multiply
    // copies of it).
    auto leaf = (int)size <= params.leaf_nodes || item.depth >= max_depth ||
                3 * size * sizeof(sdf_instr) > budget ||
                (item.depth >= 3 && size >= item.program->nodes.size());
    if (leaf) {
      auto steps                   = make_sdf_instrs(pruned, field.full);
      field.cells[item.cell].begin = (int)field.instrs.size();
      field.cells[item.cell].count = (int)steps.size();
      field.instrs.insert(field.instrs.end(), steps.begin(), steps.end());
      stored += steps.size() * sizeof(sdf_instr);
      continue;
    }
    auto children                   = (int)field.cells.size();
    field.cells[item.cell].children = children;
    field.cells.resize(field.cells.size() + 8);
    auto shared   = std::make_shared<const sdf_program>(std::move(pruned));
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
  auto count      = program.nodes.size();
  auto primitives = size_t{0};
  for (auto& node : program.nodes) primitives += is_primitive(node.type);
  if ((int)count <= params.leaf_nodes || is_empty(box) || !is_finite(box))
    return field;
  // Cubic cells (a flat object would get flat cells, split for nothing
  // along its thin axis): the root is the box grown to a cube.
  auto half = max(box.max - box.min) * 0.5f;
  field.box = {center(box) - half, center(box) + half};
  auto max_depth =
      params.max_depth >= 0 ? params.max_depth : field_depth(primitives, 1);
  auto max_bytes = params.max_bytes > 0 ? params.max_bytes
                                        : std::clamp(count * 16384,
                                              field_min_bytes, field_max_bytes);
  build_octree(field, program, params, max_depth, max_bytes);
  return field;
}

int find_sdf_cell(const sdf_field& field, vec3f p) {
  if (field.cells.empty() || !inside(field.box, p)) return invalidid;
  auto cell = 0;
  auto box  = field.box;
  while (field.cells[cell].children >= 0) {
    auto mid    = (box.min + box.max) * 0.5f;
    auto octant = (p.x >= mid.x ? 1 : 0) | (p.y >= mid.y ? 2 : 0) |
                  (p.z >= mid.z ? 4 : 0);
    box  = octant_box(box, octant);
    cell = field.cells[cell].children + octant;
  }
  return cell;
}

vec3f eval_sdf_gradient(const sdf_field& field, vec3f p, float step) {
  // One primitive in the object's space: its analytic gradient.
  auto cell = find_sdf_cell(field, p);
  if (cell >= 0 && field.cells[cell].count == 1) {
    auto& instr = field.instrs[field.cells[cell].begin];
    if (instr.space == invalidid) {
      auto single   = sdf_tape{};
      single.instrs = {sdf_instr{0, invalidid, 1, false}};
      single.nodes  = {field.full.nodes[instr.node]};
      return eval_sdf_gradient(single, p, step);
    }
  }
  if (cell < 0 && field.full.instrs.size() == 1)
    return eval_sdf_gradient(field.full, p, step);
  return normalize(tetrahedral_gradient(
      [&](vec3f q) { return eval_sdf(field, q); }, p, step));
}

size_t sdf_tape_bytes(const sdf_tape& tape) {
  return sizeof(tape) + tape.instrs.size() * sizeof(sdf_instr) +
         tape.nodes.size() * sizeof(sdf_node) +
         tape.frames.size() * sizeof(frame3f) +
         tape.spaces.size() * sizeof(int);
}

size_t sdf_field_bytes(const sdf_field& field) {
  return sizeof(field) + field.cells.size() * sizeof(sdf_cell) +
         sdf_tape_bytes(field.full) + field.instrs.size() * sizeof(sdf_instr);
}

}  // namespace implicit
