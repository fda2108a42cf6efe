// # implicit: fields of simplified tapes (implementation)

#include "sdf_field.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <thread>

#include "sdf_primitives.h"

namespace implicit {

// -----------------------------------------------------------------------------
// FIELDS
// -----------------------------------------------------------------------------

bbox3f sdf_octant_box(const bbox3f& box, int octant) {
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

// -----------------------------------------------------------------------------
// CELLS
// -----------------------------------------------------------------------------

// A cell and what building it needs, in two parts: the node that a descent
// reads (whether the cell is built, its children), 8 bytes, and the slot
// with the rest, 120 bytes. Descents through a 140,000-cell octree (the
// 10,000-sphere blend's preview) touch only nodes (1.1 MiB, against 16 MiB
// of slots), and the slot of the leaf they reach. Both live in blocks that
// never move, so readers reach a built cell without a lock; `state`
// becomes `built` (release) after the cell is complete, and the cell never
// changes after.
enum cell_state : int { unbuilt = 0, building = 1, built = 2 };
struct sdf_cell_node {
  std::atomic<int> state    = unbuilt;
  int              children = invalidid;  // as sdf_cell::children, once built
};
struct sdf_cell_slot {
  sdf_cell                    cell    = {};
  bbox3f                      box     = {};
  int                         depth   = 0;
  int                         parent  = invalidid;
  const std::vector<sdf_ssa>* clauses = nullptr;  // what it simplifies
  std::unique_ptr<std::vector<sdf_ssa>> children_clauses = {};  // interior
  int                                   children_built   = 0;
  int stalled = 0;  // levels above it, its parent's up, that dropped nothing
};

// Slot blocks of doubling sizes (1024, 2048, 4096, ...): slot i is in
// block k = floor(log2(i / 1024 + 1)), so 32 blocks hold any octree and the
// block table never grows under its readers.
static constexpr int cell_block_bits = 10;
static constexpr int cell_blocks     = 32;

struct sdf_field_cells {
  sdf_field_params                                     params    = {};
  int                                                  max_depth = 0;
  size_t                                               max_bytes = 0;
  std::array<std::atomic<sdf_cell_slot*>, cell_blocks> blocks    = {};
  std::array<std::atomic<sdf_cell_node*>, cell_blocks> nodes     = {};
  // Guarded by `mutex`: what the cells own, their count and bytes.
  std::mutex                                    mutex       = {};
  std::vector<std::unique_ptr<sdf_cell_slot[]>> owned       = {};
  std::vector<std::unique_ptr<sdf_cell_node[]>> owned_nodes = {};
  std::vector<std::unique_ptr<sdf_clause[]>>    arenas      = {};
  size_t                                        free        = 0;
  size_t                                        arena       = 0;
  int                                           count       = 0;
  size_t                                        bytes       = 0;
  // Scratch space of simplifications, reused (no allocation per cell).
  std::vector<std::unique_ptr<sdf_simplify_state>> scratch = {};
};

// The block of cell `index` and its place in the block.
struct cell_place {
  int      block  = 0;
  uint32_t offset = 0;
};
static cell_place place_of(int index) {
  auto j   = (uint32_t)index + (1u << cell_block_bits);
  auto top = 31 - __builtin_clz(j);
  return {top - cell_block_bits, j - (1u << top)};
}
static sdf_cell_slot& cell_slot(const sdf_field_cells& cells, int index) {
  auto at = place_of(index);
  return cells.blocks[at.block].load(std::memory_order_acquire)[at.offset];
}
static sdf_cell_node& cell_node(const sdf_field_cells& cells, int index) {
  auto at = place_of(index);
  return cells.nodes[at.block].load(std::memory_order_acquire)[at.offset];
}

// Append `count` slots (under the mutex); returns the first.
static int add_slots(sdf_field_cells& cells, int count) {
  auto first = cells.count;
  for (auto i = first; i < first + count; i++) {
    auto at = place_of(i);
    if (at.offset != 0) continue;
    auto size = size_t{1} << (at.block + cell_block_bits);
    cells.owned.push_back(std::make_unique<sdf_cell_slot[]>(size));
    cells.owned_nodes.push_back(std::make_unique<sdf_cell_node[]>(size));
    cells.blocks[at.block].store(
        cells.owned.back().get(), std::memory_order_release);
    cells.nodes[at.block].store(
        cells.owned_nodes.back().get(), std::memory_order_release);
    cells.bytes += (sizeof(sdf_cell_slot) + sizeof(sdf_cell_node)) * size;
  }
  cells.count += count;
  return first;
}

// Room for `count` leaf clauses in the arenas (under the mutex): arenas
// double up to 64 Ki clauses, a larger leaf gets one of its own.
static sdf_clause* add_clauses(sdf_field_cells& cells, size_t count) {
  if (cells.free < count) {
    auto size = std::max(count,
        std::min(size_t{1} << 16, std::max(size_t{1} << 10, cells.arena * 2)));
    cells.arenas.push_back(std::make_unique<sdf_clause[]>(size));
    cells.arena = size;
    cells.free  = size;
    cells.bytes += size * sizeof(sdf_clause);
  }
  auto start = cells.arenas.back().get() + (cells.arena - cells.free);
  cells.free -= count;
  return start;
}

// The deepest level a cell may split to: the field's, and one more where
// the surface of a function that is no distance bound passes with a long
// tape (the organic model's leaves there held about 105 clauses at its
// depth 6; one more level there: 1.09x, the text slab's leaves, of 33,
// unchanged; every surface leaf one level deeper: the slab 1.21x slower,
// 1.8x the memory).
static int deepest_level(const sdf_field& field, const sdf_field_cells& cells,
    bool one_sign, size_t size) {
  auto longer = (int)size > 4 * cells.params.leaf_nodes;
  return cells.max_depth + (!field.distance && !one_sign && longer ? 1 : 0);
}

// What building a cell decided, before it is published. The clauses live
// in scratch space that only grows, borrowed from the cells' pool for the
// build, instead of a vector per cell grown clause by clause (9% of a
// 10,000-cylinder slab preview's profile in reallocations; 7% less peak
// memory on the 10,000-sphere blend, time within noise).
struct cell_build {
  std::unique_ptr<sdf_simplify_state> state   = {};       // output: its clauses
  std::vector<sdf_clause>*            clauses = nullptr;  // a leaf's, or none
  sdf_cell                            cell    = {};
  bool                                split   = false;
  int stalled = 0;  // slot's stalled, with this level
};

// Simplify the clauses of slot's parent over its box and decide what the
// cell is (no lock but to borrow scratch space: reads only the parent's
// published clauses).
static cell_build simplify_cell(
    const sdf_field& field, sdf_field_cells& cells, const sdf_cell_slot& slot) {
  auto build       = cell_build{};
  auto over_budget = false;
  {
    auto lock   = std::lock_guard{cells.mutex};
    over_budget = cells.bytes > cells.max_bytes;
    if (cells.scratch.empty()) {
      build.state = std::make_unique<sdf_simplify_state>();
    } else {
      build.state = std::move(cells.scratch.back());
      cells.scratch.pop_back();
    }
  }
  auto& simplified = build.state->output;
  simplified.clear();
  // Far from the surface: a constant bound (see sdf_cell), no clauses.
  auto far   = length(slot.box.max - slot.box.min) * 0.25f;
  auto range = simplify_sdf(
      field.full, *slot.clauses, slot.box, *build.state, simplified, far);
  auto  size = simplified.size();
  auto& cell = build.cell;
  cell.range = range;
  if (is_far(range, far)) {
    cell.bound = range.lo > 0 ? range.lo : range.hi;
    return build;
  }
  // A leaf when small enough, deep enough, past the memory budget, or when
  // simplification stopped working (a chain of roundings has nothing to
  // drop: its cells would multiply copies of it). An expression gets two
  // levels without a drop: interval bounds of exp/ln blends decide a `min`
  // of two parts only in cells half the size of those that first hold both
  // (the organic model of bench/make_organic.py at 512 px: one level 8.5 s,
  // two 3.3 s, no limit 3.3 s).
  // A function that is no distance bound also stops where its range keeps
  // one sign, unless asked to split: its tracer crosses such a cell without
  // an evaluation, and smaller cells there were only more to walk through
  // (the organic model at 1024 px: 16 leaves found per missing ray before,
  // 9 now; 1.10x).
  build.stalled     = size >= slot.clauses->size() ? slot.stalled + 1 : 0;
  auto stall_levels = field.distance ? 1 : 2;
  auto one_sign     = range.lo > 0 || range.hi < 0;
  auto one_side = !field.distance && !cells.params.split_one_side && one_sign;
  auto leaf     = one_side || (int)size <= cells.params.leaf_nodes ||
              slot.depth >= deepest_level(field, cells, one_sign, size) ||
              over_budget || (slot.depth >= 3 && build.stalled >= stall_levels);
  if (!leaf) {
    build.split = true;
    return build;
  }
  build.clauses = &build.state->registers;
  build.clauses->clear();
  allocate_sdf_registers(simplified, *build.clauses);
  cell.count = (int)build.clauses->size();
  // A distance program keeps its global bound; others get their cell's
  // gradient (interval derivatives of the cell's tape).
  cell.lipschitz = field.full.lipschitz;
  if (!field.distance) {
    auto f         = eval_sdf_dual(field.full, build.clauses->data(),
                build.clauses->data() + cell.count, slot.box);
    cell.lipschitz = gradient_bound(f);
    for (auto a = 0; a < 3; a++) cell.gradient[a] = f.d[a];
  }
  return build;
}

// Build cell `index` once: the thread that claims it simplifies (outside
// the lock) and publishes (under it); others wait for it.
static const sdf_cell& build_cell(const sdf_field& field, int index) {
  auto& cells = *field.octree;
  auto& slot  = cell_slot(cells, index);
  auto& node  = cell_node(cells, index);
  auto  state = (int)unbuilt;
  if (!node.state.compare_exchange_strong(state, building)) {
    while (node.state.load(std::memory_order_acquire) != built)
      std::this_thread::yield();
    return slot.cell;
  }
  auto build = simplify_cell(field, cells, slot);
  auto lock  = std::lock_guard{cells.mutex};
  if (build.cell.count > 0) {
    build.cell.clauses = add_clauses(cells, build.clauses->size());
    std::copy(build.clauses->begin(), build.clauses->end(),
        const_cast<sdf_clause*>(build.cell.clauses));
  } else if (build.split) {
    // Its clauses stay until its 8 children are built from them.
    auto& simplified = build.state->output;
    cells.bytes += simplified.size() * sizeof(sdf_ssa);
    slot.children_clauses = std::make_unique<std::vector<sdf_ssa>>(
        simplified.begin(), simplified.end());
    build.cell.children = add_slots(cells, 8);
    for (auto octant = 0; octant < 8; octant++) {
      auto& child   = cell_slot(cells, build.cell.children + octant);
      child.box     = sdf_octant_box(slot.box, octant);
      child.depth   = slot.depth + 1;
      child.parent  = index;
      child.stalled = build.stalled;
      child.clauses = slot.children_clauses.get();
    }
  }
  cells.scratch.push_back(std::move(build.state));
  slot.cell     = build.cell;
  node.children = build.cell.children;
  node.state.store(built, std::memory_order_release);
  if (slot.parent >= 0) {
    auto& parent = cell_slot(cells, slot.parent);
    if (++parent.children_built == 8) {
      cells.bytes -= parent.children_clauses->size() * sizeof(sdf_ssa);
      parent.children_clauses.reset();
    }
  }
  return slot.cell;
}

const sdf_cell& get_sdf_cell(const sdf_field& field, int cell) {
  auto& node = cell_node(*field.octree, cell);
  if (node.state.load(std::memory_order_acquire) == built)
    return cell_slot(*field.octree, cell).cell;
  return build_cell(field, cell);
}

// The first child of cell `cell` (invalidid: a leaf), built if it was not:
// what a descent reads, from the nodes alone.
static int cell_children(const sdf_field& field, int cell) {
  auto& node = cell_node(*field.octree, cell);
  if (node.state.load(std::memory_order_acquire) == built) return node.children;
  return build_cell(field, cell).children;
}

void build_sdf_field(const sdf_field& field) {
  if (!field.octree) return;
  auto stack = std::vector<int>{0};
  while (!stack.empty()) {
    auto cell = stack.back();
    stack.pop_back();
    auto& c = get_sdf_cell(field, cell);
    if (c.children < 0) continue;
    for (auto octant = 7; octant >= 0; octant--)
      stack.push_back(c.children + octant);
  }
}

// Default budget of the cells: 16 KiB per node of the program, at least
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
  // model is 8 to 20), and functions that are no distance bound go 3 levels
  // deeper: their tracer steps by the bounds of the cells (smaller cells,
  // tighter bounds, shorter tapes to bound). An 8,000-clause text slab at
  // 240 px, 1 spp: depth 4 (as CSG) 3.6 s, 5: 2.0 s, 6: 1.5 s, 7: 1.5 s; at
  // 384 px 2 levels deeper 2.13 s, 3 levels 1.73 s; the organic model at
  // 512 px: 3.33 -> 2.02 s, the gyroid lattice 10.1 -> 9.1 s (1 thread).
  primitives = std::max(primitives, count / 16);
  if ((int)count <= params.leaf_nodes || is_empty(box) || !is_finite(box))
    return field;
  // Cubic cells (a flat object would get flat cells, split for nothing
  // along its thin axis): the root is the box grown to a cube.
  auto half       = max(box.max - box.min) * 0.5f;
  field.box       = {center(box) - half, center(box) + half};
  field.octree    = std::make_shared<sdf_field_cells>();
  auto& cells     = *field.octree;
  cells.params    = params;
  cells.max_depth = params.max_depth >= 0
                        ? params.max_depth
                        : field_depth(primitives, field.distance ? 1 : 4);
  cells.max_bytes =
      params.max_bytes > 0
          ? params.max_bytes
          : std::clamp(count * 16384, field_min_bytes, field_max_bytes);
  field.depth = cells.max_depth + (field.distance ? 0 : 1);
  add_slots(cells, 1);
  auto& root   = cell_slot(cells, 0);
  root.box     = field.box;
  root.clauses = &field.full.ssa;
  build_cell(field, 0);
  root.clauses = nullptr;  // field.full moves with the field
  return field;
}

// The octant of a cell split at `mid` that holds p; a point on a split
// plane goes the way `direction` points along that axis (zero: upper).
static int octant_towards(vec3f p, vec3f mid, vec3f direction) {
  auto upper = [&](int a) {
    return at(p, a) > at(mid, a) ||
           (at(p, a) == at(mid, a) && at(direction, a) >= 0);
  };
  return (upper(0) ? 1 : 0) | (upper(1) ? 2 : 0) | (upper(2) ? 4 : 0);
}

int find_sdf_cell(const sdf_field& field, vec3f p, bbox3f& box) {
  if (!field.octree || !inside(field.box, p)) return invalidid;
  auto cell = 0;
  box       = field.box;
  while (true) {
    auto children = cell_children(field, cell);
    if (children < 0) return cell;
    auto octant = octant_towards(p, (box.min + box.max) * 0.5f, {});
    box         = sdf_octant_box(box, octant);
    cell        = children + octant;
  }
}

int find_sdf_cell(const sdf_field& field, vec3f p) {
  auto box = bbox3f{};
  return find_sdf_cell(field, p, box);
}

int find_sdf_cell(const sdf_field& field, vec3f p, sdf_field_cursor& cursor,
    vec3f direction) {
  auto& c = cursor;
  c.cell  = invalidid;
  c.leaf  = nullptr;
  if (!field.octree || !inside(field.box, p)) return invalidid;
  // The deepest kept ancestor that holds p (the root holds it: p is inside).
  auto k = c.count - 1;
  while (k > 0 && !inside_towards(c.boxes[k], p, direction)) k--;
  if (k <= 0) {
    k          = 0;
    c.path[0]  = 0;
    c.boxes[0] = field.box;
  }
  auto cell = c.path[k];
  auto box  = c.boxes[k];
  c.count   = k + 1;
  while (true) {
    auto children = cell_children(field, cell);
    if (children < 0) break;
    auto octant = octant_towards(p, (box.min + box.max) * 0.5f, direction);
    box         = sdf_octant_box(box, octant);
    cell        = children + octant;
    if (c.count < sdf_cursor_depth) {
      c.path[c.count]  = cell;
      c.boxes[c.count] = box;
      c.count++;
    }
  }
  c.cell = cell;
  c.leaf = &get_sdf_cell(field, cell);
  c.box  = box;
  return cell;
}

interval eval_sdf_cell_interval(
    const sdf_field& field, int cell, const bbox3f& box) {
  if (cell < 0) return eval_sdf_interval(field.full, box);
  auto& leaf = get_sdf_cell(field, cell);
  if (leaf.count == 0) return leaf.range;
  return eval_sdf_interval(
      field.full, leaf.clauses, leaf.clauses + leaf.count, box);
}

vec3f eval_sdf_gradient(const sdf_field& field, vec3f p, float step) {
  // One primitive in the object's space: its analytic gradient, or its own
  // finite differences.
  if (!field.octree) return eval_sdf_gradient(field.full, p, step);
  // The samples lie in p's leaf or near it: a cursor finds their leaves
  // from there, not from the root (the same leaves, so the same values).
  auto cursor = sdf_field_cursor{};
  auto shape  = sdf_node{};
  if (find_sdf_cell(field, p, cursor) >= 0) {
    auto& leaf = *cursor.leaf;
    if (leaf.count > 0 && is_single_shape(field.full, leaf.clauses,
                              leaf.clauses + leaf.count, shape)) {
      auto g = vec3f{};
      if (eval_primitive_gradient(shape, p, g)) return g;
      return normalize(tetrahedral_gradient(
          [&](vec3f q) { return eval_primitive(shape, q); }, p, step));
    }
  }
  return normalize(tetrahedral_gradient(
      [&](vec3f q) { return eval_sdf(field, q, cursor); }, p, step));
}

size_t sdf_field_bytes(const sdf_field& field) {
  auto bytes = sizeof(field) + sdf_tape_bytes(field.full);
  if (!field.octree) return bytes;
  auto lock = std::lock_guard{field.octree->mutex};
  return bytes + sizeof(sdf_field_cells) + field.octree->bytes;
}

size_t sdf_field_cells_built(const sdf_field& field) {
  if (!field.octree) return 0;
  auto lock  = std::lock_guard{field.octree->mutex};
  auto count = size_t{0};
  for (auto i = 0; i < field.octree->count; i++)
    count += cell_node(*field.octree, i).state.load() == built;
  return count;
}

}  // namespace implicit
