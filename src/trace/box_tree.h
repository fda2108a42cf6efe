// # implicit: a tree of boxes, for what a region of space may meet
//
// A binary tree over a list of boxes: each node holds the box around its
// items, a leaf up to box_tree_leaf_size of them. The camera's first pass
// (camera_blocks.h) walks it with a block's cone of rays, so that a scene of
// thousands of objects costs a few nodes per block, not every object (a
// loop over 10,000 objects made a 1024 x 1024 preview 4.5x slower). Embree's
// BVH answers rays, not cones, hence this small tree beside it.
#pragma once

#include <vector>

#include "../math/math.h"

namespace implicit {

// Most items of a leaf.
inline constexpr int box_tree_leaf_size = 4;

// A node: its box; a leaf's items are box_tree::items[index, index + count),
// an interior node (count 0) has its children at nodes[index] and
// nodes[index + 1].
struct box_node {
  bbox3f box   = {};
  int    index = 0;
  int    count = 0;
};

// Nodes in build order (the root first, a parent before its children) and
// the items (indices into the list of boxes) in leaf order.
struct box_tree {
  std::vector<box_node> nodes = {};
  std::vector<int>      items = {};
};

// The tree of `boxes` (finite, not empty), halving the count at the median
// of the centres along their widest spread (ties by index: the same tree on
// every machine). Empty without boxes. No recursion.
box_tree make_box_tree(const std::vector<bbox3f>& boxes);

}  // namespace implicit
