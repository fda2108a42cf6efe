// # implicit: union parts of SDF programs (implementation)

#include "sdf_split.h"

#include <algorithm>

namespace implicit {

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
