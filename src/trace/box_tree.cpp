// # implicit: a tree of boxes (implementation)

#include "box_tree.h"

#include <algorithm>

namespace implicit {

// The axis of the widest spread of the centres of items [begin, end).
static int widest_axis(const std::vector<bbox3f>& boxes,
    const std::vector<int>& items, int begin, int end) {
  auto centres = bbox3f{};
  for (auto k = begin; k < end; k++)
    centres = merge(centres, center(boxes[items[k]]));
  auto extent = size(centres);
  if (extent.x >= extent.y && extent.x >= extent.z) return 0;
  return extent.y >= extent.z ? 1 : 2;
}

box_tree make_box_tree(const std::vector<bbox3f>& boxes) {
  auto tree = box_tree{};
  if (boxes.empty()) return tree;
  for (auto i = 0; i < (int)boxes.size(); i++) tree.items.push_back(i);
  struct task {
    int node = 0, begin = 0, end = 0;
  };
  tree.nodes.push_back({});
  auto stack = std::vector<task>{{0, 0, (int)boxes.size()}};
  while (!stack.empty()) {
    auto item = stack.back();
    stack.pop_back();
    if (item.end - item.begin <= box_tree_leaf_size) {
      auto& leaf = tree.nodes[item.node];
      leaf.index = item.begin;
      leaf.count = item.end - item.begin;
      for (auto k = item.begin; k < item.end; k++)
        leaf.box = merge(leaf.box, boxes[tree.items[k]]);
      continue;
    }
    auto axis   = widest_axis(boxes, tree.items, item.begin, item.end);
    auto middle = item.begin + (item.end - item.begin) / 2;
    std::nth_element(tree.items.begin() + item.begin,
        tree.items.begin() + middle, tree.items.begin() + item.end,
        [&](int a, int b) {
          auto ca = at(center(boxes[a]), axis);
          auto cb = at(center(boxes[b]), axis);
          return ca < cb || (ca == cb && a < b);
        });
    auto first                  = (int)tree.nodes.size();
    tree.nodes[item.node].index = first;
    tree.nodes.resize(first + 2);
    stack.push_back({first + 1, middle, item.end});
    stack.push_back({first, item.begin, middle});
  }
  // Children come after their parents: interior boxes from the back.
  for (auto k = (int)tree.nodes.size() - 1; k >= 0; k--) {
    auto& node = tree.nodes[k];
    if (node.count > 0) continue;
    node.box =
        merge(tree.nodes[node.index].box, tree.nodes[node.index + 1].box);
  }
  return tree;
}

}  // namespace implicit
