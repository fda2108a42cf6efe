// Tests of tapes, simplification, union parts and fields on random and large
// models.

#include "sdf_field.h"

#include <doctest/doctest.h>

#include <chrono>

#include "../math/random.h"
#include "../util/error.h"
#include "sdf_models.h"
#include "sdf_primitives.h"
#include "sdf_split.h"

namespace implicit {
namespace {

float uniform(rng_state& rng, float a, float b) {
  return a + (b - a) * rand1f(rng);
}

vec3f uniform3(rng_state& rng, float a, float b) {
  auto x = uniform(rng, a, b);
  auto y = uniform(rng, a, b);
  auto z = uniform(rng, a, b);
  return {x, y, z};
}

// A random primitive of size about `size` somewhere in [-1,1]^3, under a
// translation (and sometimes a rotation and a scale).
int random_leaf(sdf_program& program, rng_state& rng, float size) {
  auto node = sdf_node{};
  auto kind = (int)(rand1f(rng) * 4);
  switch (kind) {
    case 0:
      node.type   = sdf_type::sphere;
      node.radius = size;
      break;
    case 1:
      node.type = sdf_type::box;
      node.size = uniform3(rng, 0.5f, 1.5f) * size;
      break;
    case 2:
      node.type   = sdf_type::cylinder;
      node.height = size;
      node.radius = size * 0.5f;
      break;
    default:
      node.type    = sdf_type::torus;
      node.radius  = size;
      node.radius2 = size * 0.3f;
  }
  auto root   = add_node(program, node);
  auto offset = uniform3(rng, -1, 1);
  auto frame  = frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -offset};
  if (rand1f(rng) < 0.3f) {
    auto angle = uniform(rng, 0, 3);
    auto c = std::cos(angle), s = std::sin(angle);
    auto scale = uniform(rng, 0.7f, 1.5f);
    frame      = frame3f{vec3f{c, 0, -s} * scale, vec3f{0, 1, 0} * scale,
                vec3f{s, 0, c} * scale, {0, 0, 0}} *
            frame;
  }
  return add_transform(program, root, frame);
}

// A random model of `count` leaves: operators drawn from `types`, folded
// left or right, with transforms above some subtrees.
sdf_program random_model(rng_state& rng, int count,
    const std::vector<sdf_type>& types, float size, float blend) {
  auto program = sdf_program{};
  auto root    = random_leaf(program, rng, size);
  for (auto i = 1; i < count; i++) {
    auto leaf  = random_leaf(program, rng, size);
    auto node  = sdf_node{};
    node.type  = types[(int)(rand1f(rng) * types.size()) % types.size()];
    node.blend = blend;
    if (rand1f(rng) < 0.5f) {
      node.left  = root;
      node.right = leaf;
    } else {
      node.left  = leaf;
      node.right = root;
    }
    root = add_node(program, node);
    if (rand1f(rng) < 0.1f)
      root = add_transform(program, root,
          frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, uniform3(rng, -0.1f, 0.1f)});
    if (rand1f(rng) < 0.05f) {
      auto round   = sdf_node{};
      round.type   = sdf_type::op_round;
      round.radius = 0.01f;
      round.left   = root;
      root         = add_node(program, round);
    }
  }
  return program;
}

// Every leaf cell of a field with its box.
std::vector<std::pair<bbox3f, int>> leaf_cells(const sdf_field& field) {
  auto leaves = std::vector<std::pair<bbox3f, int>>{};
  auto stack  = std::vector<std::pair<int, bbox3f>>{{0, field.box}};
  while (!stack.empty()) {
    auto [cell, box] = stack.back();
    stack.pop_back();
    auto& c = get_sdf_cell(field, cell);
    if (c.children < 0) {
      leaves.push_back({box, cell});
      continue;
    }
    auto mid = (box.min + box.max) * 0.5f;
    for (auto o = 0; o < 8; o++) {
      auto b = box;
      for (auto a = 0; a < 3; a++) {
        if (o & (1 << a)) {
          at(b.min, a) = at(mid, a);
        } else {
          at(b.max, a) = at(mid, a);
        }
      }
      stack.push_back({c.children + o, b});
    }
  }
  return leaves;
}

}  // namespace

TEST_CASE("sdf tape: equals a direct evaluation and needs a small stack") {
  auto rng = make_rng(7);
  for (auto trial = 0; trial < 20; trial++) {
    auto program = random_model(rng, 50,
        {sdf_type::op_union, sdf_type::op_smooth_union,
            sdf_type::op_subtraction, sdf_type::op_intersection,
            sdf_type::op_smooth_subtraction, sdf_type::op_smooth_intersection},
        0.3f, 0.2f);
    auto tape    = make_sdf_tape(program);
    // The smooth ops with blend: values against a hand-written union check.
    for (auto k = 0; k < 50; k++) {
      auto p = uniform3(rng, -1.5f, 1.5f);
      CHECK(std::isfinite(eval_sdf(tape, p)));
    }
  }
  // min(a, b) of two spheres, both operand orders.
  auto program = sdf_program{};
  auto a       = sdf_node{};
  a.type       = sdf_type::sphere;
  a.radius     = 1;
  auto left    = add_node(program, a);
  auto right   = add_transform(program, add_node(program, a),
        frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-3, 0, 0}});
  auto op      = sdf_node{};
  op.type      = sdf_type::op_subtraction;
  op.left      = left;
  op.right     = right;
  add_node(program, op);
  auto tape = make_sdf_tape(program);
  CHECK(eval_sdf(tape, {0, 0, 0}) == doctest::Approx(-1));
  CHECK(eval_sdf(tape, {3, 0, 0}) == doctest::Approx(2));
  CHECK(eval_sdf(tape, {2.5f, 0, 0}) == doctest::Approx(1.5f));
}

TEST_CASE("sdf tape: a 10,000-level chain and a 50,000-operand union") {
  SUBCASE("nested transforms and unions") {
    auto program  = sdf_program{};
    auto sphere   = sdf_node{};
    sphere.type   = sdf_type::sphere;
    sphere.radius = 0.5f;
    auto root     = add_node(program, sphere);
    for (auto level = 0; level < 10000; level++) {
      root     = add_transform(program, root,
              frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1e-4f, 0, 0}});
      auto op  = sdf_node{};
      op.type  = level % 2 ? sdf_type::op_union : sdf_type::op_smooth_union;
      op.blend = 0.01f;
      op.right = root;
      op.left  = add_node(program, sphere);
      root     = add_node(program, op);
    }
    auto tape = make_sdf_tape(program);
    CHECK(eval_sdf(tape, {0, 0, 0}) < -0.4f);
    CHECK(eval_sdf(tape, {3, 0, 0}) > 0);
    auto box = sdf_bounds(program);
    CHECK(is_finite(box));
    CHECK(sdf_lipschitz(program) == 1);
    auto params      = sdf_field_params{};
    params.max_bytes = size_t{4} << 20;
    auto field       = make_sdf_field(program, expand(box, 0.1f), params);
    CHECK(eval_sdf(field, {0.6f, 0, 0}) ==
          doctest::Approx(eval_sdf(tape, {0.6f, 0, 0})).epsilon(1e-4));
  }
  SUBCASE("50,000 spheres") {
    auto program  = sdf_program{};
    auto sphere   = sdf_node{};
    sphere.type   = sdf_type::sphere;
    sphere.radius = 0.01f;
    auto root     = invalidid;
    for (auto i = 0; i < 50000; i++) {
      auto leaf = add_transform(program, add_node(program, sphere),
          frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1},
              {-(float)(i % 100), -(float)(i / 100 % 100),
                  -(float)(i / 10000)}});
      if (root == invalidid) {
        root = leaf;
        continue;
      }
      auto op  = sdf_node{};
      op.type  = sdf_type::op_union;
      op.left  = root;
      op.right = leaf;
      root     = add_node(program, op);
    }
    CHECK(eval_sdf(make_sdf_tape(program), {5, 5, 3.5f}) ==
          doctest::Approx(0.49f));
    auto parts = split_sdf_union(program);
    CHECK(parts.size() == 50000);
    CHECK(parts[7].nodes.size() == 2);
  }
  SUBCASE("a shared operand is one clause, within one space only") {
    auto program  = sdf_program{};
    auto sphere   = sdf_node{};
    sphere.type   = sdf_type::sphere;
    sphere.radius = 1;
    auto leaf     = add_node(program, sphere);
    auto op       = sdf_node{};
    op.type       = sdf_type::op_smooth_union;
    op.blend      = 0.5f;
    op.left       = leaf;
    op.right      = leaf;
    add_node(program, op);
    auto tape = make_sdf_tape(program);
    CHECK(tape.ssa.size() == 3);  // input, sphere, blend
    CHECK(eval_sdf(tape, {2, 0, 0}) == doctest::Approx(1 - 0.125f));
    // The same sphere also below a transform: two spaces.
    add_transform(
        program, leaf, frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 0}});
    op.left  = root_node(program);
    op.right = root_node(program) - 1;
    add_node(program, op);
    CHECK_THROWS_AS(make_sdf_tape(program), io_error);
  }
}

TEST_CASE("sdf prune: pruned programs equal the whole one in every cell") {
  auto rng   = make_rng(11);
  auto kinds = std::vector<std::vector<sdf_type>>{
      {sdf_type::op_union},
      {sdf_type::op_smooth_union},
      {sdf_type::op_subtraction, sdf_type::op_union},
      {sdf_type::op_intersection, sdf_type::op_union},
      {sdf_type::op_smooth_subtraction, sdf_type::op_smooth_union},
      {sdf_type::op_smooth_intersection, sdf_type::op_smooth_union,
          sdf_type::op_union},
      {sdf_type::op_union, sdf_type::op_smooth_union, sdf_type::op_subtraction,
          sdf_type::op_intersection, sdf_type::op_smooth_subtraction,
          sdf_type::op_smooth_intersection},
  };
  auto models = 0, smaller = 0, constant = 0;
  for (auto trial = 0; trial < 28; trial++) {
    auto& types       = kinds[trial % kinds.size()];
    auto  count       = 40 + trial * 10;
    auto  program     = random_model(rng, count, types, 0.15f, 0.1f);
    auto  tape        = make_sdf_tape(program);
    auto  box         = bbox3f{{-1.3f, -1.3f, -1.3f}, {1.3f, 1.3f, 1.3f}};
    auto  params      = sdf_field_params{};
    params.leaf_nodes = 8;
    params.max_depth  = 3;
    auto field        = make_sdf_field(program, box, params);
    REQUIRE((bool)field.octree);
    models++;
    auto leaves = leaf_cells(field);
    for (auto& [cell, index] : leaves) {
      auto& leaf = get_sdf_cell(field, index);
      if (leaf.count == 0) {
        // A constant cell: a bound of the field's sign, no larger in size.
        for (auto k = 0; k < 8; k++) {
          auto p = cell.min + (cell.max - cell.min) * uniform3(rng, 0, 1);
          auto expected = eval_sdf(tape, p), bound = eval_sdf(field, p);
          CHECK(bound * expected > 0);
          CHECK(std::abs(bound) <= std::abs(expected) + 1e-5f);
          CHECK(std::abs(bound) >= length(cell.max - cell.min) * 0.25f);
        }
        constant++;
        continue;
      }
      if (leaf.count < (int)tape.clauses.size()) smaller++;
      for (auto k = 0; k < 8; k++) {
        auto p        = cell.min + (cell.max - cell.min) * uniform3(rng, 0, 1);
        auto expected = eval_sdf(tape, p);
        CHECK(find_sdf_cell(field, p) == index);
        CHECK(eval_sdf(field, p) ==
              doctest::Approx(expected).epsilon(1e-4).scale(1));
      }
    }
    // Outside the box the whole program answers.
    CHECK(eval_sdf(field, {2, 2, 2}) == eval_sdf(tape, {2, 2, 2}));
  }
  CHECK(models == 28);
  CHECK(smaller > 0);
  CHECK(constant > 0);
}

TEST_CASE("sdf prune: hard and smooth unions shrink to the near operands") {
  // A row of 64 unit-spaced spheres: a cell around one sphere keeps it and
  // its neighbours only.
  for (auto type : {sdf_type::op_union, sdf_type::op_smooth_union}) {
    auto program = sdf_program{};
    auto root    = invalidid;
    for (auto i = 0; i < 64; i++) {
      auto sphere   = sdf_node{};
      sphere.type   = sdf_type::sphere;
      sphere.radius = 0.4f;
      auto leaf     = add_transform(program, add_node(program, sphere),
              frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-(float)i, 0, 0}});
      if (root == invalidid) {
        root = leaf;
        continue;
      }
      auto op  = sdf_node{};
      op.type  = type;
      op.blend = 0.6f;
      op.left  = root;
      op.right = leaf;
      root     = add_node(program, op);
    }
    auto pruned = simplify_sdf(make_sdf_tape(program),
        bbox3f{{9.8f, -0.2f, -0.2f}, {10.2f, 0.2f, 0.2f}});
    auto leaves = 0;
    for (auto& clause : pruned.ssa) leaves += clause.op == sdf_op::shape;
    CHECK(leaves >= 1);
    CHECK(leaves <= 4);
    CHECK(eval_sdf(pruned, {10, 0, 0.1f}) ==
          doctest::Approx(eval_sdf(make_sdf_tape(program), {10, 0, 0.1f})));
  }
}

TEST_CASE("sdf split: union parts keep their transforms and the rest") {
  auto program  = sdf_program{};
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 1;
  auto plane    = sdf_node{};
  plane.type    = sdf_type::plane;
  auto a        = add_transform(program, add_node(program, sphere),
             frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-5, 0, 0}});
  auto b        = add_node(program, plane);
  auto op       = sdf_node{};
  op.type       = sdf_type::op_union;
  op.left       = a;
  op.right      = b;
  auto u        = add_node(program, op);
  auto c        = add_node(program, sphere);
  op.left       = u;
  op.right      = c;
  auto root     = add_node(program, op);
  add_transform(
      program, root, frame3f{{2, 0, 0}, {0, 2, 0}, {0, 0, 2}, {0, -4, 0}});
  auto parts = split_sdf_union(program);
  REQUIRE(parts.size() == 3);
  // Each part equals the whole where it is the minimum.
  auto p     = vec3f{2.5f, 2.3f, 0.1f};  // near the first sphere
  auto whole = make_sdf_tape(program);
  CHECK(eval_sdf(make_sdf_tape(parts[0]), p) ==
        doctest::Approx(eval_sdf(whole, p)));
  auto q = vec3f{0.1f, 2.2f, 0};  // near the second sphere
  CHECK(eval_sdf(make_sdf_tape(parts[1]), q) ==
        doctest::Approx(eval_sdf(whole, q)));
  CHECK(!is_finite(sdf_bounds(parts[2])));  // the plane
  auto everywhere = sdf_program{};
  everywhere.nodes.push_back(sphere);
  CHECK(split_sdf_union(everywhere).size() == 1);
}

TEST_CASE("sdf prune: a smooth blob keeps a few operands per cell") {
  // 1,000 blended spheres on a jittered 10^3 lattice, as the loader combines
  // an `operands` list (balanced pairs), and the same spheres folded left:
  // both are one smooth union group, so a small cell around a middle sphere
  // keeps the same few operands of either (those within a blend of the
  // least upper end: 4 here), where a tree of binary smooth minima kept
  // 33 of the balanced tree and 136 of the left fold.
  auto balanced = make_sdf_model(sdf_model_type::smooth_union, 1000, 7);
  auto leaves   = std::vector<int>{};
  auto op       = sdf_node{};
  for (auto i = 0; i < (int)balanced.nodes.size(); i++) {
    auto& node = balanced.nodes[i];
    if (node.type == sdf_type::op_transform) leaves.push_back(i);
    if (node.type == sdf_type::op_smooth_union) op = node;
  }
  REQUIRE(leaves.size() == 1000);
  auto left_fold = balanced;  // the spheres, their blends come after them
  left_fold.nodes.resize(leaves.back() + 1);
  auto root = leaves[0];
  for (auto i = 1; i < 1000; i++) {
    op.left  = root;
    op.right = leaves[i];
    root     = add_node(left_fold, op);
  }
  auto count = [](const sdf_tape& tape) {
    auto shapes = 0;
    for (auto& clause : tape.ssa) shapes += clause.op == sdf_op::shape;
    return shapes;
  };
  // Sphere 555 (lattice cell 5, 5, 5): its centre is minus the translation.
  auto& frame  = balanced.frames[balanced.nodes[leaves[555]].frame];
  auto  centre = -frame.o;
  auto  cell   = bbox3f{centre - 0.02f, centre + 0.02f};  // spacing 0.2
  auto  pruned = simplify_sdf(make_sdf_tape(balanced), cell);
  auto  folded = simplify_sdf(make_sdf_tape(left_fold), cell);
  CHECK(count(pruned) <= 6);
  CHECK(count(folded) == count(pruned));
  auto rng            = make_rng(5);
  auto balanced_tape  = make_sdf_tape(balanced);
  auto left_fold_tape = make_sdf_tape(left_fold);
  for (auto k = 0; k < 16; k++) {
    auto p     = cell.min + (cell.max - cell.min) * uniform3(rng, 0, 1);
    auto whole = eval_sdf(balanced_tape, p);
    CHECK(eval_sdf(left_fold_tape, p) == whole);  // one function
    CHECK(eval_sdf(pruned, p) == whole);          // the same floats
    CHECK(eval_sdf(folded, p) == whole);
  }
}

TEST_CASE("sdf field: a cursor finds the leaf a search from the root finds") {
  // Walks of small steps (the cursor climbs a level or two), jumps, points
  // on split planes (octant boundaries are half open) and on the box's
  // upper faces (inside the field, outside every half-open box there).
  auto rng          = make_rng(23);
  auto program      = random_model(rng, 200, {sdf_type::op_union}, 0.1f, 0.05f);
  auto box          = bbox3f{{-1, -1, -1}, {1, 1, 1}};
  auto params       = sdf_field_params{};
  params.leaf_nodes = 1;
  params.max_depth  = 6;
  auto field        = make_sdf_field(program, box, params);
  REQUIRE((bool)field.octree);
  auto cursor = sdf_field_cursor{};
  auto p      = vec3f{0, 0, 0};
  auto deep   = 0;
  for (auto k = 0; k < 20000; k++) {
    auto r = rand1f(rng);
    if (r < 0.8f) {
      p = clamp(p + uniform3(rng, -0.02f, 0.02f), -1.0f, 1.0f);
    } else if (r < 0.9f) {
      p = uniform3(rng, -1.1f, 1.1f);  // some outside
    } else {
      // Octant planes at depth 1 to 6: multiples of 2^-d, exact in float.
      auto step                     = std::ldexp(1.0f, -(int)(rand1f(rng) * 6));
      p                             = uniform3(rng, -1, 1);
      at(p, (int)(rand1f(rng) * 3)) = std::round(p.x / step) * step;
      if (rand1f(rng) < 0.2f) at(p, (int)(rand1f(rng) * 3)) = 1;
    }
    auto expected_box = bbox3f{};
    auto expected     = find_sdf_cell(field, p, expected_box);
    auto found        = find_sdf_cell(field, p, cursor);
    REQUIRE(found == expected);
    if (expected < 0) {
      CHECK(cursor.leaf == nullptr);
      continue;
    }
    CHECK(cursor.box.min == expected_box.min);
    CHECK(cursor.box.max == expected_box.max);
    CHECK(cursor.leaf == &get_sdf_cell(field, expected));
    deep += cursor.count >= 5;
  }
  CHECK(deep > 1000);
}

TEST_CASE("sdf field: a gradient is the whole field's finite differences") {
  // The four samples of a normal are found from the centre's leaf (a
  // cursor), not from the root: the same leaves, so the same floats, near
  // leaf borders too (samples in other leaves than the centre's).
  auto rng     = make_rng(31);
  auto program = random_model(
      rng, 300, {sdf_type::op_smooth_union, sdf_type::op_union}, 0.1f, 0.05f);
  auto params       = sdf_field_params{};
  params.leaf_nodes = 2;
  params.max_depth  = 6;
  auto field = make_sdf_field(program, {{-1, -1, -1}, {1, 1, 1}}, params);
  REQUIRE((bool)field.octree);
  auto crossing = 0;
  for (auto k = 0; k < 3000; k++) {
    auto step = k % 2 ? 1e-3f : 0.05f;  // the second crosses leaves often
    auto p    = uniform3(rng, -1.05f, 1.05f);
    auto g    = eval_sdf_gradient(field, p, step);
    auto cell = find_sdf_cell(field, p);
    auto leaf = cell >= 0 ? &get_sdf_cell(field, cell) : nullptr;
    auto one  = sdf_node{};
    if (leaf && leaf->count > 0 &&
        is_single_shape(
            field.full, leaf->clauses, leaf->clauses + leaf->count, one))
      continue;  // the primitive's own gradient
    auto expected = normalize(tetrahedral_gradient(
        [&](vec3f q) { return eval_sdf(field, q); }, p, step));
    REQUIRE(g.x == expected.x);
    REQUIRE(g.y == expected.y);
    REQUIRE(g.z == expected.z);
    auto corner = p + vec3f{step, -step, -step};
    crossing += find_sdf_cell(field, corner) != cell;
  }
  CHECK(crossing > 300);
}

TEST_CASE(
    "sdf field: a point on a face lies in the cell its direction enters") {
  // A ray leaving a cell by a face: the point on the face is found in the
  // cell beyond it, below the face when the ray goes down that axis.
  auto rng          = make_rng(29);
  auto program      = random_model(rng, 200, {sdf_type::op_union}, 0.1f, 0.05f);
  auto params       = sdf_field_params{};
  params.leaf_nodes = 1;
  params.max_depth  = 6;
  auto field = make_sdf_field(program, {{-1, -1, -1}, {1, 1, 1}}, params);
  REQUIRE((bool)field.octree);
  auto cursor = sdf_field_cursor{};
  auto faces  = 0;
  for (auto k = 0; k < 5000; k++) {
    auto step   = std::ldexp(1.0f, -(int)(rand1f(rng) * 6));
    auto p      = uniform3(rng, -1, 1);
    auto axis   = (int)(rand1f(rng) * 3);
    at(p, axis) = std::round(at(p, axis) / step) * step;
    if (std::abs(at(p, axis)) == 1) continue;
    auto below      = p;
    at(below, axis) = std::nextafter(at(p, axis), -2.0f);
    auto down       = vec3f{0, 0, 0};
    at(down, axis)  = -1;
    auto lower = find_sdf_cell(field, below), upper = find_sdf_cell(field, p);
    CHECK(find_sdf_cell(field, p, cursor, down) == lower);
    CHECK(find_sdf_cell(field, p, cursor, -down) == upper);
    faces += lower != upper;
  }
  CHECK(faces > 1000);
}

}  // namespace implicit
