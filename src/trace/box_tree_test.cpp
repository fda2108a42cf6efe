// Tests of the tree of boxes: every item in one leaf, leaves of at most
// box_tree_leaf_size items, each node's box the union of what it holds,
// children after their parents, and the same tree from the same boxes.

#include "box_tree.h"

#include <doctest/doctest.h>

#include "../math/random.h"

using namespace implicit;

namespace {

// `count` seeded boxes of random sizes in [-10, 10]^3, a quarter of them
// sharing one centre (ties of the median split).
std::vector<bbox3f> random_boxes(int count) {
  auto rng   = make_rng(5);
  auto boxes = std::vector<bbox3f>{};
  for (auto k = 0; k < count; k++) {
    auto c = k % 4 == 0 ? vec3f{1, 2, 3}
                        : vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} * 20 -
                              vec3f{10, 10, 10};
    auto h = rand1f(rng) + 0.01f;
    boxes.push_back({c - vec3f{h, h, h}, c + vec3f{h, 2 * h, h}});
  }
  return boxes;
}

bool same_box(const bbox3f& a, const bbox3f& b) {
  return a.min == b.min && a.max == b.max;
}

}  // namespace

TEST_CASE("box tree: leaves hold every item once, nodes bound what they hold") {
  CHECK(make_box_tree({}).nodes.empty());
  for (auto count : {1, 4, 5, 37, 1000}) {
    CAPTURE(count);
    auto boxes = random_boxes(count);
    auto tree  = make_box_tree(boxes);
    REQUIRE(tree.items.size() == boxes.size());
    auto seen  = std::vector<int>(count, 0);
    auto whole = bbox3f{};
    for (auto& box : boxes) whole = merge(whole, box);
    CHECK(same_box(tree.nodes[0].box, whole));
    auto depth  = std::vector<int>(tree.nodes.size(), 0);
    auto leaves = 0;
    for (auto k = 0; k < (int)tree.nodes.size(); k++) {
      auto& node = tree.nodes[k];
      if (node.count > 0) {
        leaves++;
        CHECK(node.count <= box_tree_leaf_size);
        auto box = bbox3f{};
        for (auto i = node.index; i < node.index + node.count; i++) {
          seen[tree.items[i]]++;
          box = merge(box, boxes[tree.items[i]]);
        }
        CHECK(same_box(node.box, box));
        continue;
      }
      REQUIRE(node.index > k);
      REQUIRE(node.index + 1 < (int)tree.nodes.size());
      auto& a = tree.nodes[node.index];
      auto& b = tree.nodes[node.index + 1];
      CHECK(same_box(node.box, merge(a.box, b.box)));
      depth[node.index] = depth[node.index + 1] = depth[k] + 1;
    }
    for (auto n : seen) CHECK(n == 1);
    CHECK(leaves == (int)tree.nodes.size() / 2 + 1);
    // Median splits: a depth of about log2(count / 4).
    auto deepest = *std::max_element(depth.begin(), depth.end());
    CHECK((1 << deepest) <= std::max(1, count / 2));
    // The same boxes give the same tree.
    auto again = make_box_tree(boxes);
    CHECK(again.items == tree.items);
    REQUIRE(again.nodes.size() == tree.nodes.size());
    for (size_t k = 0; k < tree.nodes.size(); k++) {
      CHECK(again.nodes[k].index == tree.nodes[k].index);
      CHECK(again.nodes[k].count == tree.nodes[k].count);
    }
  }
}
