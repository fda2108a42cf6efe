// # implicit: SDF tapes (compilation and register allocation)

#include "sdf_tape.h"

#include <algorithm>
#include <array>
#include <string>

#include "../util/error.h"
#include "sdf_primitives.h"

namespace implicit {

// -----------------------------------------------------------------------------
// CLAUSES
// -----------------------------------------------------------------------------

int sdf_op_inputs(sdf_op op) {
  switch (op) {
    case sdf_op::input:
    case sdf_op::smooth_open: return 0;
    case sdf_op::smooth_close:
    case sdf_op::map:
    case sdf_op::twist:
    case sdf_op::bend:
    case sdf_op::repeat:
    case sdf_op::elongate:
    case sdf_op::mirror:
    case sdf_op::shape:
    case sdf_op::scale:
    case sdf_op::csg_round:
    case sdf_op::csg_onion: return 1;
    case sdf_op::csg_union:
    case sdf_op::csg_intersection:
    case sdf_op::csg_subtraction:
    case sdf_op::csg_smooth_union:
    case sdf_op::csg_smooth_intersection:
    case sdf_op::csg_smooth_subtraction:
    case sdf_op::smooth_add: return 2;
    // var-x/y/z read a point.
    case sdf_op::math_x:
    case sdf_op::math_y:
    case sdf_op::math_z:
      IMPLICIT_SDF_IMMEDIATE_CASES
      return 1;
      // clang-format off
#define IMPLICIT_SDF_OP_INPUTS_0(id)
#define IMPLICIT_SDF_OP_INPUTS_1(id) case sdf_op::id: return 1;
#define IMPLICIT_SDF_OP_INPUTS_2(id) case sdf_op::id: return 2;
#define IMPLICIT_SDF_OP_INPUTS(id, name, operands) \
  IMPLICIT_SDF_OP_INPUTS_##operands(id)
    case sdf_op::math_const: return 0;
    IMPLICIT_SDF_MATH(IMPLICIT_SDF_OP_INPUTS)
      // clang-format on
#undef IMPLICIT_SDF_OP_INPUTS
#undef IMPLICIT_SDF_OP_INPUTS_2
#undef IMPLICIT_SDF_OP_INPUTS_1
#undef IMPLICIT_SDF_OP_INPUTS_0
  }
  return 0;
}

// -----------------------------------------------------------------------------
// COMPILATION
// -----------------------------------------------------------------------------

namespace {

// The space a node is evaluated in: the point of its nearest domain
// operator above it (or the input), then the transforms below that one,
// composed into one map.
struct tape_space {
  int   warp    = invalidid;  // that domain operator's node; none: the input
  int   frame   = invalidid;  // composed map, in sdf_tape::frames; or none
  float stretch = 1;          // bound of the map's stretch
};

// Program -> SSA clauses.
struct tape_compiler {
  const sdf_program&      program;
  sdf_tape&               tape;
  std::vector<int>        space       = {};  // per node, in `spaces`
  std::vector<tape_space> spaces      = {};
  std::vector<int>        value       = {};  // per node: its clause
  std::vector<int>        warp_point  = {};  // per domain operator: its point
  std::vector<int>        space_point = {};  // per space: its point clause
  std::vector<char>       absorbed    = {};  // find_smooth_groups
  std::vector<int>        group       = {};  // per group root: its last add

  int emit(sdf_op op, int a = invalidid, int b = invalidid, uint32_t p = 0) {
    tape.ssa.push_back({op, a, b, p});
    return (int)tape.ssa.size() - 1;
  }
};

std::string node_name(const sdf_program& program, int index) {
  return "sdf program: node " + std::to_string(index) + " (" +
         sdf_type_names[(int)program.nodes[index].type] + ")";
}

// Throw unless every operand comes before its user, and transforms have
// their frames.
void check_program(const sdf_program& program) {
  for (auto i = 0; i < (int)program.nodes.size(); i++) {
    auto& node  = program.nodes[i];
    auto  count = sdf_operand_count(node.type);
    for (auto k = 0; k < count; k++) {
      auto operand = k == 0 ? node.left : node.right;
      if (operand < 0 || operand >= i)
        throw io_error(node_name(program, i) + " has operand " +
                       std::to_string(operand) + ", expected an earlier node");
    }
    if (node.type == sdf_type::op_transform &&
        (node.frame < 0 || node.frame >= (int)program.frames.size()))
      throw io_error(node_name(program, i) + " has no frame");
  }
}

// Spaces, top-down from the root (users come after their operands, so a
// reverse pass sees every user of a node before the node): a transform
// composes its frame after the map of its own space (as the stack tape did,
// so points map to the same floats), a domain operator starts a space at
// its output point. A shared node must be used within one space.
void assign_spaces(tape_compiler& compiler) {
  auto& program = compiler.program;
  auto& tape    = compiler.tape;
  auto  n       = (int)program.nodes.size();
  compiler.space.assign(n, invalidid);
  compiler.spaces       = {tape_space{}};
  compiler.space[n - 1] = 0;
  for (auto i = n - 1; i >= 0; i--) {
    auto s = compiler.space[i];
    if (s < 0) continue;  // not reached from the root
    auto& node  = program.nodes[i];
    auto  inner = s;
    if (node.type == sdf_type::op_transform) {
      auto  outer = compiler.spaces[s];
      auto& frame = program.frames[node.frame];
      auto  scale = program.frame_scales[node.frame];
      tape.frames.push_back(
          outer.frame < 0 ? frame : frame * tape.frames[outer.frame]);
      tape.stretches.push_back(scale > 0 ? outer.stretch / scale : flt_inf);
      compiler.spaces.push_back(
          {outer.warp, (int)tape.frames.size() - 1, tape.stretches.back()});
      inner = (int)compiler.spaces.size() - 1;
    } else if (is_warp(node.type)) {
      compiler.spaces.push_back({i, invalidid, 1});
      inner = (int)compiler.spaces.size() - 1;
    }
    auto count = sdf_operand_count(node.type);
    for (auto k = 0; k < count; k++) {
      auto  operand  = k == 0 ? node.left : node.right;
      auto& assigned = compiler.space[operand];
      if (assigned >= 0 && assigned != inner)
        throw io_error(node_name(program, operand) +
                       " is shared by users in different spaces");
      assigned = inner;
    }
  }
}

// The point clause of a space: its domain operator's point (or the input),
// mapped by its frame (one map clause per space, made when first needed).
int point_of_space(tape_compiler& compiler, int s) {
  auto& space = compiler.spaces[s];
  auto  base  = space.warp < 0 ? 0 : compiler.warp_point[space.warp];
  if (space.frame < 0) return base;
  auto& point = compiler.space_point[s];
  if (point < 0)
    point = compiler.emit(sdf_op::map, base, invalidid, space.frame);
  return point;
}

// A copy of node `index` in the tape's pool; returns its index there.
uint32_t pool_node(tape_compiler& compiler, int index, int frame) {
  auto node   = compiler.program.nodes[index];
  node.frame  = frame;
  node.origin = index;
  compiler.tape.nodes.push_back(node);
  return (uint32_t)compiler.tape.nodes.size() - 1;
}

// The clause of a math node whose operands are clauses a and b; math on
// constants is folded into a constant.
int emit_math(tape_compiler& compiler, sdf_op op, int a, int b) {
  auto& ssa      = compiler.tape.ssa;
  auto  constant = [&](int k) {
    return k < 0 || ssa[k].op == sdf_op::math_const;
  };
  if (constant(a) && constant(b)) {
    auto x = a < 0 ? 0.0f : sdf_param_float(ssa[a].param);
    auto y = b < 0 ? 0.0f : sdf_param_float(ssa[b].param);
    return compiler.emit(sdf_op::math_const, invalidid, invalidid,
        sdf_float_param(eval_sdf_math(op, x, y)));
  }
  return compiler.emit(op, a, b);
}

// The clause holding the value of node `index`, whose operands have theirs.
int emit_node(tape_compiler& compiler, int index) {
  auto& program = compiler.program;
  auto& node    = program.nodes[index];
  auto  s       = compiler.space[index];
  auto  left    = node.left >= 0 ? compiler.value[node.left] : invalidid;
  auto  right   = node.right >= 0 ? compiler.value[node.right] : invalidid;
  auto  f       = [](float value) { return sdf_float_param(value); };
  auto  emit    = [&](sdf_op op, uint32_t param) {
    return compiler.emit(op, left, right, param);
  };
  switch (node.type) {
    IMPLICIT_SDF_PRIMITIVE_CASES {
      auto& space = compiler.spaces[s];
      auto  base  = space.warp < 0 ? 0 : compiler.warp_point[space.warp];
      return compiler.emit(sdf_op::shape, base, invalidid,
          pool_node(compiler, index, space.frame));
    }
    case sdf_type::op_union: return emit(sdf_op::csg_union, 0);
    case sdf_type::op_intersection: return emit(sdf_op::csg_intersection, 0);
    case sdf_type::op_subtraction: return emit(sdf_op::csg_subtraction, 0);
    case sdf_type::op_smooth_union:
      return emit(sdf_op::csg_smooth_union, f(node.blend));
    case sdf_type::op_smooth_intersection:
      return emit(sdf_op::csg_smooth_intersection, f(node.blend));
    case sdf_type::op_smooth_subtraction:
      return emit(sdf_op::csg_smooth_subtraction, f(node.blend));
    case sdf_type::op_round: return emit(sdf_op::csg_round, f(node.radius));
    case sdf_type::op_onion: return emit(sdf_op::csg_onion, f(node.thickness));
    case sdf_type::op_transform: {
      // Its map is in its operand's space; only a distance factor other
      // than 1 (a scaling map) is left to apply.
      auto scale = program.frame_scales[node.frame];
      return scale == 1 ? left : emit(sdf_op::scale, f(scale));
    }
      IMPLICIT_SDF_WARP_CASES return left;
    case sdf_type::math_const: return emit(sdf_op::math_const, f(node.value));
    case sdf_type::math_x:
    case sdf_type::math_y:
    case sdf_type::math_z: {
      auto op = node.type == sdf_type::math_x   ? sdf_op::math_x
                : node.type == sdf_type::math_y ? sdf_op::math_y
                                                : sdf_op::math_z;
      return compiler.emit(op, point_of_space(compiler, s));
    }
#define IMPLICIT_SDF_EMIT_MATH_0(id)
#define IMPLICIT_SDF_EMIT_MATH_1(id) \
  case sdf_type::id:                 \
    return emit_math(compiler, sdf_op::id, left, invalidid);
#define IMPLICIT_SDF_EMIT_MATH_2(id) \
  case sdf_type::id:                 \
    return emit_math(compiler, sdf_op::id, left, right);
#define IMPLICIT_SDF_EMIT_MATH(id, name, operands) \
  IMPLICIT_SDF_EMIT_MATH_##operands(id)
      IMPLICIT_SDF_MATH(IMPLICIT_SDF_EMIT_MATH)
#undef IMPLICIT_SDF_EMIT_MATH
#undef IMPLICIT_SDF_EMIT_MATH_2
#undef IMPLICIT_SDF_EMIT_MATH_1
#undef IMPLICIT_SDF_EMIT_MATH_0
  }
  return invalidid;
}

// The point clause of a domain operator.
sdf_op warp_op(sdf_type type) {
  switch (type) {
    case sdf_type::op_twist: return sdf_op::twist;
    case sdf_type::op_bend: return sdf_op::bend;
    case sdf_type::op_repeat: return sdf_op::repeat;
    case sdf_type::op_elongate: return sdf_op::elongate;
    case sdf_type::op_mirror:
      return sdf_op::mirror;
      IMPLICIT_SDF_PRIMITIVE_CASES
      IMPLICIT_SDF_CSG_CASES
      IMPLICIT_SDF_MATH_CASES break;
  }
  return sdf_op::input;
}

// Whether node `index` is the root of a smooth union group of 3 operands or
// more (smaller ones stay one binary clause).
bool is_group_root(const tape_compiler& compiler, int index) {
  auto& node = compiler.program.nodes[index];
  return node.type == sdf_type::op_smooth_union && !compiler.absorbed[index] &&
         (compiler.absorbed[node.left] || compiler.absorbed[node.right]);
}

// One step of emit_clauses' walk: visit a node (expand it, or emit it once
// its operands are), or put operand `index` into the group of `root`.
enum class walk_step { visit, emit, add };
struct walk_item {
  int       index = 0;
  walk_step step  = walk_step::visit;
  int       root  = invalidid;
};

// Morton codes of the centres of a group's operands' boxes, 10 bits an
// axis over the box of those centres (non-finite centres last): sorted by
// them, operands that lie close together come together in the tape, and so
// do their nodes and maps in memory (sdf_tape::nodes and frames follow the
// clauses), whatever the order of the scene's list. A group's value does
// not depend on the order of its operands.
std::vector<uint32_t> spatial_keys(
    const std::vector<bbox3f>& bounds, const std::vector<int>& operands) {
  auto centres = std::vector<vec3f>{};
  auto extent  = bbox3f{};
  for (auto k : operands) {
    centres.push_back(center(bounds[k]));
    if (isfinite(centres.back())) extent = merge(extent, centres.back());
  }
  auto spread = [](uint32_t v) {  // 10 bits to every third of 30
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    return (v | (v << 2)) & 0x09249249u;
  };
  auto keys = std::vector<uint32_t>{};
  for (auto& c : centres) {
    if (!isfinite(c)) {
      keys.push_back(0xFFFFFFFFu);
      continue;
    }
    auto key = 0u;
    for (auto a = 0; a < 3; a++) {
      auto lo = at(extent.min, a), hi = at(extent.max, a);
      auto t = hi > lo ? (at(c, a) - lo) / (hi - lo) : 0.0f;
      key |= spread((uint32_t)std::clamp(t * 1023.0f, 0.0f, 1023.0f)) << a;
    }
    keys.push_back(key);
  }
  return keys;
}

// A group's operands: those needing more registers first, then in space
// order (spatial_keys).
void sort_group_operands(const std::vector<bbox3f>& bounds,
    const std::vector<int>& need, std::vector<int>& group) {
  auto keys  = spatial_keys(bounds, group);
  auto order = std::vector<int>(group.size());
  for (auto k = 0; k < (int)order.size(); k++) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    auto na = need[group[a]], nb = need[group[b]];
    return na != nb ? na > nb : keys[a] < keys[b];
  });
  for (auto& k : order) k = group[k];
  group = order;
}

// Clauses in evaluation order: a post-order walk from the root with an
// explicit stack, each node once (shared nodes are one clause), the operand
// needing more registers first (Sethi and Ullman 1970: a tree of n leaves
// then needs at most log2(n) + 1 registers, whatever its shape). A domain
// operator's point clause comes before its operand's clauses. A group adds
// each operand to its accumulator right after the operand's clauses, so one
// operand value is live at a time however many the group has; it opens the
// accumulator after its first operand (the one needing most registers: a
// nested group there closes before its user's opens).
void emit_clauses(tape_compiler& compiler) {
  auto& nodes       = compiler.program.nodes;
  auto  n           = (int)nodes.size();
  auto  need        = std::vector<int>(n, 1);
  auto  group       = std::vector<int>{};
  auto  bounds      = std::vector<bbox3f>{};  // of every node, for groups
  compiler.absorbed = find_smooth_groups(compiler.program);
  for (auto i = 0; i < n; i++) {
    auto& node  = nodes[i];
    auto  count = sdf_operand_count(node.type);
    if (is_group_root(compiler, i)) {
      smooth_group_operands(compiler.program, compiler.absorbed, i, group);
      for (auto k : group) need[i] = std::max(need[i], need[k]);
    } else if (count == 1) {
      need[i] = need[node.left];
    } else if (count == 2) {
      auto l = need[node.left], r = need[node.right];
      need[i] = l == r ? l + 1 : std::max(l, r);
    }
  }
  compiler.value.assign(n, invalidid);
  compiler.group.assign(n, invalidid);
  compiler.warp_point.assign(n, invalidid);
  compiler.space_point.assign(compiler.spaces.size(), invalidid);
  compiler.emit(sdf_op::input);
  auto stack = std::vector<walk_item>{{n - 1}};
  while (!stack.empty()) {
    auto item = stack.back();
    stack.pop_back();
    auto index = item.index;
    if (item.step == walk_step::add) {
      auto& acc = compiler.group[item.root];
      if (acc < 0) acc = compiler.emit(sdf_op::smooth_open);
      acc = compiler.emit(sdf_op::smooth_add, acc, compiler.value[index],
          sdf_float_param(nodes[item.root].blend));
      continue;
    }
    if (compiler.value[index] >= 0) continue;  // shared, already emitted
    auto& node  = nodes[index];
    auto  count = sdf_operand_count(node.type);
    if (item.step == walk_step::visit && is_group_root(compiler, index)) {
      stack.push_back({index, walk_step::emit});
      smooth_group_operands(compiler.program, compiler.absorbed, index, group);
      if (bounds.empty()) bounds = sdf_node_bounds(compiler.program);
      sort_group_operands(bounds, need, group);
      for (auto k = (int)group.size() - 1; k >= 0; k--) {
        stack.push_back({group[k], walk_step::add, index});
        stack.push_back({group[k]});
      }
      continue;
    }
    if (item.step == walk_step::visit && count > 0) {
      if (is_warp(node.type) && compiler.warp_point[index] < 0) {
        auto in = point_of_space(compiler, compiler.space[index]);
        compiler.warp_point[index] = compiler.emit(warp_op(node.type), in,
            invalidid, pool_node(compiler, index, invalidid));
      }
      stack.push_back({index, walk_step::emit});
      auto first = node.left, second = node.right;
      if (count == 2 && need[node.right] > need[node.left])
        std::swap(first, second);
      if (count == 2) stack.push_back({second});
      stack.push_back({first});
      continue;
    }
    compiler.value[index] =
        is_group_root(compiler, index)
            ? compiler.emit(sdf_op::smooth_close, compiler.group[index],
                  invalidid, sdf_float_param(node.blend))
            : emit_node(compiler, index);
  }
}

// Renumber the maps in the order the clauses first use them (with the
// sorted groups above: maps of operands close in space close in memory).
void order_frames_by_use(sdf_tape& tape) {
  auto count = (int)tape.frames.size();
  auto index = std::vector<int>(count, invalidid);
  auto order = std::vector<int>{};
  auto use   = [&](int frame) {
    if (frame < 0 || index[frame] >= 0) return;
    index[frame] = (int)order.size();
    order.push_back(frame);
  };
  for (auto& c : tape.ssa) {
    if (c.op == sdf_op::map) use((int)c.param);
    if (c.op == sdf_op::shape) use(tape.nodes[c.param].frame);
  }
  for (auto frame = 0; frame < count; frame++) use(frame);  // unused ones
  auto frames    = std::vector<frame3f>(count);
  auto stretches = std::vector<float>(count);
  for (auto k = 0; k < count; k++) {
    frames[k]    = tape.frames[order[k]];
    stretches[k] = tape.stretches[order[k]];
  }
  tape.frames    = std::move(frames);
  tape.stretches = std::move(stretches);
  for (auto& c : tape.ssa)
    if (c.op == sdf_op::map) c.param = (uint32_t)index[c.param];
  for (auto& node : tape.nodes)
    if (node.frame >= 0) node.frame = index[node.frame];
}

// Drop the clauses that nothing reads (the operands of folded constants),
// keeping the order.
void remove_dead_clauses(std::vector<sdf_ssa>& ssa) {
  auto n      = (int)ssa.size();
  auto live   = std::vector<char>(n, 0);
  live[n - 1] = 1;
  for (auto i = n - 1; i >= 0; i--) {
    if (!live[i]) continue;
    auto inputs = sdf_op_inputs(ssa[i].op);
    if (inputs >= 1) live[ssa[i].a] = 1;
    if (inputs >= 2) live[ssa[i].b] = 1;
  }
  auto index = std::vector<int>(n, invalidid);
  auto count = 0;
  for (auto i = 0; i < n; i++) {
    if (!live[i]) continue;
    auto clause = ssa[i];
    auto inputs = sdf_op_inputs(clause.op);
    if (inputs >= 1) clause.a = index[clause.a];
    if (inputs >= 2) clause.b = index[clause.b];
    index[i]     = count;
    ssa[count++] = clause;
  }
  ssa.resize(count);
}

}  // namespace

sdf_tape make_sdf_tape(const sdf_program& program) {
  auto tape = sdf_tape{};
  if (program.nodes.empty()) return tape;
  check_program(program);
  auto compiler = tape_compiler{program, tape};
  assign_spaces(compiler);
  emit_clauses(compiler);
  // The root's value must be the last clause (a transform or a domain
  // operator at the root passes its operand's clause through).
  auto root = compiler.value[program.nodes.size() - 1];
  if (root != (int)tape.ssa.size() - 1) {
    auto& last = tape.ssa[root];
    tape.ssa.push_back(last);
  }
  remove_dead_clauses(tape.ssa);
  order_frames_by_use(tape);
  if (!allocate_sdf_registers(tape.ssa, tape.clauses))
    throw io_error("sdf program: needs more than " +
                   std::to_string(sdf_max_registers) + " values or " +
                   std::to_string(sdf_max_points) + " points or " +
                   std::to_string(sdf_max_groups) +
                   " smooth union groups at once (too many shared "
                   "subexpressions, or groups nested too deep)");
  tape.lipschitz = sdf_lipschitz(program);
  tape.jumps     = std::any_of(tape.clauses.begin(), tape.clauses.end(),
          [](const sdf_clause& c) { return is_jump_op(c.op); });
  return tape;
}

// -----------------------------------------------------------------------------
// REGISTER ALLOCATION
// -----------------------------------------------------------------------------

namespace {

// Free registers of one file, lowest first: the never-used ones count up
// from `next`, the freed ones wait in a stack (no allocation: the octree
// allocates registers for every cell it builds).
struct register_file {
  int count = 0, next = 0, freed = 0;
  // Not cleared: a place is written before it is read (this runs once per
  // octree leaf, 116,000 times in a 10,000-sphere blend's preview).
  std::array<uint8_t, sdf_max_registers> stack;
  explicit register_file(int count_) : count{count_} {}
  bool take(int& reg) {
    if (freed > 0) {
      reg = stack[--freed];
    } else if (next < count) {
      reg = next++;
    } else {
      return false;
    }
    return true;
  }
  void give(int reg) { stack[freed++] = (uint8_t)reg; }
};

// The immediate form of a binary math clause (sdf_tape.h) whose second
// operand is a constant, its operands swapped first where that is exact
// (a sum or product of floats does not depend on their order; min and max
// may, on ties of -0 and +0); else the clause as it is.
sdf_ssa with_immediate(const std::vector<sdf_ssa>& ssa, sdf_ssa c) {
  auto immediate = c.op;
  switch (c.op) {
#define IMPLICIT_SDF_IMMEDIATE_OP(id) \
  case sdf_op::id: immediate = sdf_op::id##_k; break;
    IMPLICIT_SDF_IMMEDIATE_OPS(IMPLICIT_SDF_IMMEDIATE_OP)
#undef IMPLICIT_SDF_IMMEDIATE_OP
    default: return c;
  }
  auto constant = [&](int k) { return ssa[k].op == sdf_op::math_const; };
  auto commutes = c.op == sdf_op::math_add || c.op == sdf_op::math_mul;
  if (commutes && constant(c.a) && !constant(c.b)) std::swap(c.a, c.b);
  if (!constant(c.b)) return c;
  return {immediate, c.a, invalidid, ssa[c.b].param};
}

}  // namespace

// Reverse linear scan (fidget's compiler/alloc.rs): walking from the root
// back, a value is given a register where it is last read and gives it back
// where it is written, so a register is reused as soon as its value is dead.
// A clause may write the register it reads (its inputs are read first).
// A constant read only as an immediate operand (with_immediate) is dead.
bool allocate_sdf_registers(
    const std::vector<sdf_ssa>& ssa, std::vector<sdf_clause>& clauses) {
  auto n = (int)ssa.size();
  if (n == 0) return true;
  auto scalars = register_file{sdf_max_registers};
  auto points  = register_file{sdf_max_points};
  auto groups  = register_file{sdf_max_groups};
  // Each clause's register: on the stack for a cell's tape (one call per
  // octree leaf), on the heap for a long whole tape.
  std::array<int, 1024> local;  // filled below, as far as n

  auto heap = std::vector<int>{};
  auto reg  = local.data();
  if (n > (int)local.size()) {
    heap.resize(n);
    reg = heap.data();
  }
  std::fill(reg, reg + n, invalidid);
  auto start = clauses.size();
  auto file  = [&](int index) -> register_file& {
    auto op = ssa[index].op;
    return is_point_op(op) ? points : is_group_op(op) ? groups : scalars;
  };
  if (!file(n - 1).take(reg[n - 1])) return false;
  for (auto i = n - 1; i >= 0; i--) {
    if (reg[i] < 0) continue;  // dead: nothing reads it
    auto c = with_immediate(ssa, ssa[i]);
    file(i).give(reg[i]);
    auto clause  = sdf_clause{};
    clause.op    = c.op;
    clause.out   = (uint8_t)reg[i];
    clause.param = c.param;
    auto inputs  = sdf_op_inputs(c.op);
    for (auto k = 0; k < inputs; k++) {
      auto in = k == 0 ? c.a : c.b;
      if (reg[in] < 0 && !file(in).take(reg[in])) {
        clauses.resize(start);
        return false;
      }
      (k == 0 ? clause.a : clause.b) = (uint8_t)reg[in];
    }
    clauses.push_back(clause);
  }
  std::reverse(clauses.begin() + start, clauses.end());
  return true;
}

bool is_single_shape(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, sdf_node& shape) {
  if (end - begin != 2 || begin[0].op != sdf_op::input ||
      begin[1].op != sdf_op::shape)
    return false;
  shape = pool.nodes[begin[1].param];
  return shape.frame < 0;
}

size_t sdf_tape_bytes(const sdf_tape& tape) {
  return sizeof(tape) + tape.clauses.size() * sizeof(sdf_clause) +
         tape.ssa.size() * sizeof(sdf_ssa) +
         tape.nodes.size() * sizeof(sdf_node) +
         tape.frames.size() * sizeof(frame3f) +
         tape.stretches.size() * sizeof(float);
}

}  // namespace implicit
