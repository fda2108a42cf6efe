// Tests of tapes: every clause at points against closed forms, batches
// against single points, DAG sharing, constant folding, domain operators and
// the register files.

#include "sdf_tape.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "../math/random.h"
#include "../util/error.h"
#include "sdf_expression.h"
#include "sdf_primitives.h"
#include "sdf_tape_eval.h"

namespace implicit {
namespace {

sdf_node make_math(sdf_type type, int left = invalidid, int right = invalidid) {
  auto node  = sdf_node{};
  node.type  = type;
  node.left  = left;
  node.right = right;
  return node;
}

int add_const(sdf_program& program, float value) {
  auto node  = make_math(sdf_type::math_const);
  node.value = value;
  return add_node(program, node);
}

// op(x) or op(x, y) over the point's coordinates.
sdf_tape math_tape(sdf_type type, int operands) {
  auto program = sdf_program{};
  auto x       = add_node(program, make_math(sdf_type::math_x));
  auto y       = add_node(program, make_math(sdf_type::math_y));
  add_node(program, make_math(type, x, operands == 2 ? y : invalidid));
  return make_sdf_tape(program);
}

float uniform(rng_state& rng, float a, float b) {
  return a + (b - a) * rand1f(rng);
}

// The same float, or both NaN.
bool same(float a, float b) { return a == b || (a != a && b != b); }

}  // namespace

TEST_CASE("sdf tape: every math clause at points") {
  auto pi = 3.14159265f;
  struct unary_case {
    sdf_type type;
    float    x, expected;
  };
  // Closed forms, NaN outside the domains.
  for (auto [type, x, expected] : std::vector<unary_case>{
           {sdf_type::math_neg, 2, -2}, {sdf_type::math_abs, -3, 3},
           {sdf_type::math_square, -3, 9}, {sdf_type::math_sqrt, 16, 4},
           {sdf_type::math_sqrt, -1, flt_nan}, {sdf_type::math_exp, 0, 1},
           {sdf_type::math_log, 1, 0}, {sdf_type::math_log, -1, flt_nan},
           {sdf_type::math_log, 0, -flt_inf}, {sdf_type::math_sin, pi / 2, 1},
           {sdf_type::math_cos, 0, 1}, {sdf_type::math_tan, 0, 0},
           {sdf_type::math_asin, 1, pi / 2}, {sdf_type::math_asin, 2, flt_nan},
           {sdf_type::math_acos, 1, 0}, {sdf_type::math_atan, 1, pi / 4},
           {sdf_type::math_floor, -1.5f, -2}, {sdf_type::math_ceil, -1.5f, -1},
           {sdf_type::math_round, 2.5f, 3}, {sdf_type::math_round, -2.5f, -3},
           {sdf_type::math_not, 0, 1}, {sdf_type::math_not, 3, 0}}) {
    INFO(sdf_type_names[(int)type], " at ", x);
    auto value = eval_sdf(math_tape(type, 1), {x, 0, 0});
    if (std::isnan(expected) || std::isinf(expected)) {
      CHECK(same(value, expected));
    } else {
      CHECK(value == doctest::Approx(expected).epsilon(1e-6));
    }
  }
  struct binary_case {
    sdf_type type;
    float    x, y, expected;
  };
  for (auto [type, x, y, expected] :
      std::vector<binary_case>{{sdf_type::math_add, 2, 3, 5},
          {sdf_type::math_sub, 2, 3, -1}, {sdf_type::math_mul, 2, 3, 6},
          {sdf_type::math_div, 3, 2, 1.5f}, {sdf_type::math_div, 1, 0, flt_inf},
          {sdf_type::math_min, 2, 3, 2}, {sdf_type::math_max, 2, 3, 3},
          {sdf_type::math_min, flt_nan, 3, flt_nan},
          {sdf_type::math_max, 3, flt_nan, flt_nan},
          {sdf_type::math_atan2, 1, -1, 3 * pi / 4},
          {sdf_type::math_mod, -1, 3, 2}, {sdf_type::math_mod, 7, -3, 1},
          {sdf_type::math_compare, 1, 2, -1}, {sdf_type::math_compare, 2, 2, 0},
          {sdf_type::math_compare, 3, 2, 1},
          {sdf_type::math_compare, flt_nan, 2, flt_nan},
          {sdf_type::math_and, 0, 5, 0}, {sdf_type::math_and, 2, 5, 5},
          {sdf_type::math_or, 0, 5, 5}, {sdf_type::math_or, 2, 5, 2}}) {
    INFO(sdf_type_names[(int)type], " at ", x, ", ", y);
    auto value = eval_sdf(math_tape(type, 2), {x, y, 0});
    if (std::isnan(expected) || std::isinf(expected)) {
      CHECK(same(value, expected));
    } else {
      CHECK(value == doctest::Approx(expected).epsilon(1e-6));
    }
  }
  // var-z, and a constant.
  auto program = sdf_program{};
  auto z       = add_node(program, make_math(sdf_type::math_z));
  add_node(program, make_math(sdf_type::math_add, z, add_const(program, 0.5f)));
  CHECK(eval_sdf(make_sdf_tape(program), {1, 2, 3}) == 3.5f);
}

TEST_CASE("sdf tape: constants fold, shared clauses are computed once") {
  // (2 + 3) * x: one constant.
  auto program = sdf_program{};
  auto sum =
      add_node(program, make_math(sdf_type::math_add, add_const(program, 2),
                            add_const(program, 3)));
  auto x = add_node(program, make_math(sdf_type::math_x));
  add_node(program, make_math(sdf_type::math_mul, sum, x));
  auto tape      = make_sdf_tape(program);
  auto constants = 0;
  for (auto& clause : tape.ssa) constants += clause.op == sdf_op::math_const;
  CHECK(constants == 1);
  CHECK(tape.ssa.size() == 4);  // input, 5, x, mul
  CHECK(eval_sdf(tape, {2, 0, 0}) == 10);
  // s = x * x + 1, then s * s + s: a DAG, s computed once.
  auto dag = sdf_program{};
  auto dx  = add_node(dag, make_math(sdf_type::math_x));
  auto xx  = add_node(dag, make_math(sdf_type::math_mul, dx, dx));
  auto s  = add_node(dag, make_math(sdf_type::math_add, xx, add_const(dag, 1)));
  auto ss = add_node(dag, make_math(sdf_type::math_mul, s, s));
  add_node(dag, make_math(sdf_type::math_add, ss, s));
  auto dag_tape = make_sdf_tape(dag);
  CHECK(dag_tape.ssa.size() == 7);  // input x xx 1 s ss root
  CHECK(eval_sdf(dag_tape, {2, 0, 0}) == 30);
}

// The rounded box and the warps of the domain operator tests.
static sdf_node test_box() {
  auto box   = sdf_node{};
  box.type   = sdf_type::rounded_box;
  box.size   = {0.3f, 0.6f, 0.2f};
  box.radius = 0.05f;
  return box;
}
static sdf_node test_warp(sdf_type type) {
  auto node  = sdf_node{};
  node.type  = type;
  node.value = 1.3f;
  node.size  = {0.25f, 0, 1.5f};
  node.count = {2, -1, -1};
  node.axes  = 5;  // x and z
  return node;
}
// The test box under a rotation, then warped by `warp` (its operand set
// here); returns the warp's node.
static int add_warped_box(sdf_program& program, sdf_node warp) {
  warp.left = add_transform(program, add_node(program, test_box()),
      frame3f{{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}, {0.1f, 0, 0}});
  return add_node(program, warp);
}

TEST_CASE("sdf tape: domain operators as documented") {
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.5f;
  auto box      = test_box();
  auto rng      = make_rng(3);
  auto warp     = test_warp;
  // The maps of sdf_program.h, written out.
  auto expected_point = [](const sdf_node& w, vec3f p) {
    auto q = p;
    switch (w.type) {
      case sdf_type::op_twist: {
        auto c = std::cos(w.value * p.y), s = std::sin(w.value * p.y);
        q = {c * p.x - s * p.z, p.y, s * p.x + c * p.z};
        break;
      }
      case sdf_type::op_bend: {
        auto c = std::cos(w.value * p.x), s = std::sin(w.value * p.x);
        q = {c * p.x - s * p.y, s * p.x + c * p.y, p.z};
        break;
      }
      case sdf_type::op_repeat: {
        auto n = std::clamp(std::round(p.x / w.size.x), -2.0f, 2.0f);
        q.x    = p.x - w.size.x * n;
        q.z    = p.z - w.size.z * std::round(p.z / w.size.z);
        break;
      }
      case sdf_type::op_elongate:
        q = p - vec3f{std::clamp(p.x, -w.size.x, w.size.x), 0,
                    std::clamp(p.z, -w.size.z, w.size.z)};
        break;
      case sdf_type::op_mirror: q = {std::abs(p.x), p.y, std::abs(p.z)}; break;
      default: break;
    }
    return q;
  };
  for (auto type : {sdf_type::op_twist, sdf_type::op_bend, sdf_type::op_repeat,
           sdf_type::op_elongate, sdf_type::op_mirror}) {
    auto w       = warp(type);
    auto program = sdf_program{};
    // The operand is a box under a rotation, warped, then moved: the map
    // before the warp and the one after both apply.
    add_transform(program, add_warped_box(program, w),
        frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -0.2f, 0}});
    auto tape = make_sdf_tape(program);
    for (auto k = 0; k < 200; k++) {
      auto p =
          vec3f{uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3)};
      auto q = expected_point(w, p + vec3f{0, -0.2f, 0});
      auto r = frame3f{{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}, {0.1f, 0, 0}};
      INFO(sdf_type_names[(int)type], " at ", p.x, " ", p.y, " ", p.z);
      CHECK(eval_sdf(tape, p) ==
            doctest::Approx(eval_primitive(box, transform_point(r, q)))
                .epsilon(1e-5));
    }
  }
  // A domain operator below a math clause: displacement of a repeated
  // sphere, sphere(repeat(p)) + 0.1 sin(10 x), both in the repeated space.
  auto program = sdf_program{};
  auto leaf    = add_node(program, sphere);
  auto x       = add_node(program, make_math(sdf_type::math_x));
  auto ten_x   = add_node(
        program, make_math(sdf_type::math_mul, add_const(program, 10), x));
  auto wave = add_node(
      program, make_math(sdf_type::math_mul, add_const(program, 0.1f),
                   add_node(program, make_math(sdf_type::math_sin, ten_x))));
  auto sum = add_node(program, make_math(sdf_type::math_add, leaf, wave));
  auto w   = warp(sdf_type::op_repeat);
  w.left   = sum;
  add_node(program, w);
  auto tape = make_sdf_tape(program);
  for (auto k = 0; k < 100; k++) {
    auto p =
        vec3f{uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3)};
    auto q = expected_point(w, p);
    CHECK(eval_sdf(tape, p) ==
          doctest::Approx(eval_primitive(sphere, q) + 0.1f * std::sin(10 * q.x))
              .epsilon(1e-5));
  }
}

TEST_CASE("sdf tape: CSG programs give the stack tape's floats") {
  // A reference evaluation in node order, with each primitive's maps
  // composed from the root down as the stack tape composed them: the tape
  // must give the same floats (same formulas, same order).
  auto rng = make_rng(17);
  for (auto trial = 0; trial < 20; trial++) {
    auto program = sdf_program{};
    auto roots   = std::vector<int>{};
    for (auto i = 0; i < 30; i++) {
      auto node    = sdf_node{};
      node.type    = (i % 3 == 0)   ? sdf_type::sphere
                     : (i % 3 == 1) ? sdf_type::torus
                                    : sdf_type::capsule;
      node.radius  = uniform(rng, 0.1f, 0.3f);
      node.radius2 = 0.05f;
      node.height  = 0.2f;
      auto frame   = frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1},
          {uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)}};
      if (i % 4 == 0)
        frame =
            frame3f{{0.6f, 0.8f, 0}, {-0.8f, 0.6f, 0}, {0, 0, 1}, {}} * frame;
      roots.push_back(add_transform(program, add_node(program, node), frame));
    }
    auto types =
        std::vector<sdf_type>{sdf_type::op_union, sdf_type::op_smooth_union,
            sdf_type::op_subtraction, sdf_type::op_smooth_intersection};
    auto root = roots[0];
    for (auto i = 1; i < (int)roots.size(); i++) {
      auto op  = sdf_node{};
      op.type  = types[(i + trial) % types.size()];
      op.blend = 0.2f;
      op.left  = root;
      op.right = roots[i];
      root     = add_node(program, op);
      if (i % 5 == 0)
        root = add_transform(program, root,
            frame3f{{2, 0, 0}, {0, 2, 0}, {0, 0, 2}, {0.1f, 0, 0}});
      if (i % 7 == 0) {
        auto round   = sdf_node{};
        round.type   = i % 2 ? sdf_type::op_round : sdf_type::op_onion;
        round.radius = round.thickness = 0.02f;
        round.left                     = root;
        root                           = add_node(program, round);
      }
    }
    auto n      = (int)program.nodes.size();
    auto frames = std::vector<frame3f>(n);
    auto mapped = std::vector<char>(n, 0);
    for (auto i = n - 1; i >= 0; i--) {
      auto& node  = program.nodes[i];
      auto  frame = frames[i];
      auto  has   = mapped[i];
      if (node.type == sdf_type::op_transform) {
        auto& f = program.frames[node.frame];
        frame   = has ? f * frame : f;
        has     = 1;
      }
      for (auto k : {node.left, node.right}) {
        if (k < 0) continue;
        frames[k] = frame;
        mapped[k] = has;
      }
    }
    auto tape = make_sdf_tape(program);
    for (auto k = 0; k < 50; k++) {
      auto p      = vec3f{uniform(rng, -1.5f, 1.5f), uniform(rng, -1.5f, 1.5f),
          uniform(rng, -1.5f, 1.5f)};
      auto values = std::vector<float>(n);
      for (auto i = 0; i < n; i++) {
        auto& node = program.nodes[i];
        auto  l    = node.left >= 0 ? values[node.left] : 0.0f;
        auto  r    = node.right >= 0 ? values[node.right] : 0.0f;
        switch (node.type) {
          case sdf_type::op_union: values[i] = std::min(l, r); break;
          case sdf_type::op_subtraction: values[i] = std::max(l, -r); break;
          case sdf_type::op_smooth_union:
            values[i] = smooth_min(l, r, node.blend);
            break;
          case sdf_type::op_smooth_intersection:
            values[i] = smooth_max(l, r, node.blend);
            break;
          case sdf_type::op_round: values[i] = l - node.radius; break;
          case sdf_type::op_onion:
            values[i] = std::abs(l) - node.thickness;
            break;
          case sdf_type::op_transform: {
            auto s    = program.frame_scales[node.frame];
            values[i] = s == 1 ? l : l * s;
            break;
          }
          default: {
            auto q    = mapped[i] ? transform_point(frames[i], p) : p;
            values[i] = eval_primitive(node, q);
          }
        }
      }
      CHECK(eval_sdf(tape, p) == values[n - 1]);
    }
  }
}

TEST_CASE("sdf tape: batches equal single points") {
  auto rng = make_rng(5);
  // A math expression with domain operators, and a CSG model.
  auto program  = sdf_program{};
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.4f;
  auto leaf     = add_node(program, sphere);
  auto x        = add_node(program, make_math(sdf_type::math_x));
  auto y        = add_node(program, make_math(sdf_type::math_y));
  auto g        = add_node(
             program, make_math(sdf_type::math_mul,
                          add_node(program, make_math(sdf_type::math_sin, x)),
                          add_node(program, make_math(sdf_type::math_cos, y))));
  auto m   = add_node(program, make_math(sdf_type::math_max, leaf, g));
  auto tw  = sdf_node{};
  tw.type  = sdf_type::op_twist;
  tw.value = 2;
  tw.left  = m;
  add_node(program, tw);
  auto tape = make_sdf_tape(program);
  // 1-8 points take the narrow lanes of a march's batch, more the wide ones.
  for (auto count : {1, 3, 8, 9, 31, 32, 33, 1000}) {
    auto points = std::vector<vec3f>(count);
    for (auto& p : points)
      p = {uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2)};
    auto values = std::vector<float>(count);
    eval_sdf(tape, points.data(), values.data(), points.size());
    for (auto i = 0; i < count; i++)
      CHECK(same(values[i], eval_sdf(tape, points[i])));
  }
}

TEST_CASE("sdf tape: constant operands become immediates") {
  // (x - 0.5) / 0.25 + 2 * y: each constant is its clause's parameter.
  auto program = sdf_program{};
  auto x       = add_node(program, make_math(sdf_type::math_x));
  auto y       = add_node(program, make_math(sdf_type::math_y));
  auto u       = add_node(
            program, make_math(sdf_type::math_sub, x, add_const(program, 0.5f)));
  auto v = add_node(
      program, make_math(sdf_type::math_div, u, add_const(program, 0.25f)));
  auto w = add_node(program,
      make_math(sdf_type::math_mul, add_const(program, 2), y));  // swapped
  add_node(program, make_math(sdf_type::math_add, v, w));
  auto tape  = make_sdf_tape(program);
  auto count = [](const sdf_tape& t, sdf_op op) {
    return std::count_if(t.clauses.begin(), t.clauses.end(),
        [&](const sdf_clause& c) { return c.op == op; });
  };
  CHECK(count(tape, sdf_op::math_const) == 0);
  CHECK(tape.clauses.size() == tape.ssa.size() - 3);
  CHECK(count(tape, sdf_op::math_mul_k) == 1);
  auto rng = make_rng(7);
  for (auto i = 0; i < 100; i++) {
    auto p = vec3f{uniform(rng, -2, 2), uniform(rng, -2, 2), 0};
    CHECK(eval_sdf(tape, p) == (p.x - 0.5f) / 0.25f + 2.0f * p.y);
    auto g = gradient(eval_sdf_dual(tape, p));
    CHECK(g.x == 4);
    CHECK(g.y == 2);
    auto box = bbox3f{p - vec3f{0.1f, 0.1f, 0.1f}, p + vec3f{0.1f, 0.1f, 0.1f}};
    auto range = eval_sdf_interval(tape, box);
    CHECK(range.lo <= eval_sdf(tape, p));
    CHECK(range.hi >= eval_sdf(tape, p));
    CHECK(range.hi - range.lo == doctest::Approx(0.2f * 4 + 0.2f * 2));
  }
  // 2 - x keeps its constant (a difference is no sum), and so does a
  // constant that a clause without an immediate form also reads.
  auto kept = sdf_program{};
  auto kx   = add_node(kept, make_math(sdf_type::math_x));
  auto two  = add_const(kept, 2);
  auto d    = add_node(kept, make_math(sdf_type::math_sub, two, kx));
  auto m    = add_node(kept, make_math(sdf_type::math_mod, kx, two));
  auto l    = add_node(kept, make_math(sdf_type::math_min, m, two));
  add_node(kept, make_math(sdf_type::math_add, d, l));
  auto kept_tape = make_sdf_tape(kept);
  CHECK(count(kept_tape, sdf_op::math_const) == 1);
  CHECK(count(kept_tape, sdf_op::math_min_k) == 1);
  CHECK(eval_sdf(kept_tape, {3.5f, 0, 0}) == (2 - 3.5f) + 1.5f);
}

TEST_CASE("sdf tape: register files") {
  // 65,536 spheres in a balanced union: a few registers.
  auto program = sdf_program{};
  auto sphere  = sdf_node{};
  sphere.type  = sdf_type::sphere;
  auto roots   = std::vector<int>{};
  for (auto i = 0; i < 65536; i++) roots.push_back(add_node(program, sphere));
  auto op = sdf_node{};
  op.type = sdf_type::op_smooth_union;
  fold_sdf_operands(program, roots, op);
  auto tape = make_sdf_tape(program);
  auto most = 0;
  for (auto& clause : tape.clauses) most = std::max(most, (int)clause.out + 1);
  CHECK(most <= 18);
  // n values all read twice, far apart (two sums in opposite orders): all
  // live at once. 200 fit in 256 registers, 300 are refused.
  for (auto n : {200, 300}) {
    auto dag    = sdf_program{};
    auto x      = add_node(dag, make_math(sdf_type::math_x));
    auto values = std::vector<int>{};
    for (auto i = 0; i < n; i++)
      values.push_back(add_node(
          dag, make_math(sdf_type::math_add, x, add_const(dag, (float)i))));
    auto first = values[0], second = values[n - 1];
    for (auto i = 1; i < n; i++) {
      first  = add_node(dag, make_math(sdf_type::math_add, first, values[i]));
      second = add_node(
          dag, make_math(sdf_type::math_max, second, values[n - 1 - i]));
    }
    add_node(dag, make_math(sdf_type::math_sub, first, second));
    if (n == 200) {
      auto dag_tape = make_sdf_tape(dag);
      // sum(x + i) - max(x + i) at x = 1: 200 + 19900 - 200.
      CHECK(eval_sdf(dag_tape, {1, 0, 0}) == 19900);
    } else {
      CHECK_THROWS_AS(make_sdf_tape(dag), io_error);
    }
  }
}

}  // namespace implicit

namespace implicit {

// Spheres of radius 0.3 at `centres`, listed in `order`, smooth-unioned with
// blend 0.5 as a scene's `operands` list (fold_sdf_operands), or nested
// left by hand.
static sdf_program blob_program(const std::vector<vec3f>& centres,
    const std::vector<int>& order, bool nest) {
  auto program = sdf_program{};
  auto roots   = std::vector<int>{};
  for (auto i : order) {
    auto sphere   = sdf_node{};
    sphere.type   = sdf_type::sphere;
    sphere.radius = 0.3f;
    roots.push_back(add_transform(program, add_node(program, sphere),
        frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -centres[i]}));
  }
  auto op  = sdf_node{};
  op.type  = sdf_type::op_smooth_union;
  op.blend = 0.5f;
  if (!nest) {
    fold_sdf_operands(program, roots, op);
    return program;
  }
  auto root = roots[0];
  for (size_t i = 1; i < roots.size(); i++) {
    op.left  = root;
    op.right = roots[i];
    root     = add_node(program, op);
  }
  return program;
}

TEST_CASE("sdf tape: a smooth union group folds its sorted values") {
  // 14 spheres, the last 10 at one centre (more than sdf_smooth_group_size
  // equal values): the value at p folds smooth_min over the 8 smallest
  // distances in increasing order, whatever the list's order or nesting.
  auto rng     = make_rng(29);
  auto centres = std::vector<vec3f>{};
  for (auto i = 0; i < 14; i++)
    centres.push_back(
        i < 4 ? vec3f{uniform(rng, -0.6f, 0.6f), uniform(rng, -0.6f, 0.6f), 0}
              : vec3f{0.2f, -0.1f, 0.3f});
  auto order = std::vector<int>{};
  for (auto i = 0; i < 14; i++) order.push_back(i);
  auto shuffled =
      std::vector<int>{9, 2, 13, 0, 5, 11, 3, 7, 1, 12, 4, 10, 8, 6};
  auto tapes =
      std::vector<sdf_tape>{make_sdf_tape(blob_program(centres, order, false)),
          make_sdf_tape(blob_program(centres, shuffled, false)),
          make_sdf_tape(blob_program(centres, shuffled, true))};
  auto groups = 0;
  for (auto& clause : tapes[0].ssa) groups += clause.op == sdf_op::smooth_open;
  CHECK(groups == 1);
  for (auto k = 0; k < 200; k++) {
    auto p = vec3f{uniform(rng, -1.5f, 1.5f), uniform(rng, -1.5f, 1.5f),
        uniform(rng, -1.5f, 1.5f)};
    auto d = std::vector<float>{};
    for (auto& c : centres) {
      auto q = transform_point(frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -c}, p);
      d.push_back(length(q) - 0.3f);
    }
    std::sort(d.begin(), d.end());
    auto expected = smooth_min_sorted(d.data(), sdf_smooth_group_size, 0.5f);
    for (auto& tape : tapes) {
      CHECK(eval_sdf(tape, p) == expected);
      auto batch = 0.0f;
      eval_sdf(tape, &p, &batch, 1);
      CHECK(batch == expected);
      // The gradient: central differences of the value.
      auto dual = eval_sdf_dual(tape, p);
      CHECK(dual.v == expected);
      for (auto a = 0; a < 3; a++) {
        auto h     = vec3f{0, 0, 0};
        at(h, a)   = 1e-3f;
        auto slope = (eval_sdf(tape, p + h) - eval_sdf(tape, p - h)) / 2e-3f;
        CHECK(at(gradient(dual), a) == doctest::Approx(slope).epsilon(0.02));
      }
      // Boxes about p hold it, and their gradients hold its gradient.
      auto box   = bbox3f{p - 0.05f, p + 0.05f};
      auto range = eval_sdf_interval(tape, box);
      auto duals = eval_sdf_dual(tape, box);
      CHECK(range.lo <= expected);
      CHECK(expected <= range.hi);
      for (auto a = 0; a < 3; a++) {
        CHECK(duals.d[a].lo <= dual.d[a]);
        CHECK(dual.d[a] <= duals.d[a].hi);
      }
    }
  }
  // Two operands stay one binary clause (the same function).
  auto pair = make_sdf_tape(blob_program(centres, {0, 1}, false));
  for (auto& clause : pair.ssa) CHECK(clause.op != sdf_op::smooth_open);
}

TEST_CASE(
    "sdf tape: a group's floats go where the sorted insertion puts them") {
  // The branch-free insertion of floats against insert_smallest (which the
  // dual values use): the same values in the same places, the same count
  // and NaN flag, over sequences with repeats, signed zeros and infinities.
  auto rng     = make_rng(41);
  auto choices = std::vector<float>{
      0.0f, -0.0f, 1.0f, -1.0f, 0.5f, flt_inf, -flt_inf, 2.0f, std::nanf("")};
  for (auto run = 0; run < 2000; run++) {
    auto fast = sdf_smooth_floats{}, sorted = sdf_smooth_floats{};
    smooth_open(fast);
    smooth_open(sorted);
    auto length = rand1i(rng, 20);
    for (auto i = 0; i < length; i++) {
      auto nan = run % 4 == 0 && rand1i(rng, 16) == 0;
      auto x =
          rand1i(rng, 2) ? choices[rand1i(rng, 8)] : uniform(rng, -2.0f, 2.0f);
      if (nan) x = choices[8];
      smooth_insert(fast, x);
      insert_smallest(sorted, x);
      REQUIRE(fast.count == sorted.count);
      REQUIRE(fast.nan == sorted.nan);
      for (auto k = 0; k < sorted.count; k++)
        REQUIRE(std::memcmp(&fast.v[k], &sorted.v[k], sizeof(float)) == 0);
    }
    auto a = smooth_fold(fast, 0.3f), b = smooth_fold(sorted, 0.3f);
    CHECK(std::memcmp(&a, &b, sizeof(float)) == 0);
  }
}

TEST_CASE("sdf tape: a group's operands are ordered in space") {
  // A 6 x 6 x 6 lattice of spheres listed in order and shuffled compiles to
  // one tape: the same clauses, nodes and maps (a group's operands sorted by
  // the Morton code of their boxes' centres, the maps by first use), so a
  // shuffled list reads memory as the lattice does.
  auto centres = std::vector<vec3f>{};
  for (auto z = 0; z < 6; z++)
    for (auto y = 0; y < 6; y++)
      for (auto x = 0; x < 6; x++)
        centres.push_back(vec3f{(float)x, (float)y, (float)z} * 0.5f);
  auto order = std::vector<int>{};
  for (auto i = 0; i < (int)centres.size(); i++) order.push_back(i);
  auto shuffled = order;
  auto rng      = make_rng(5);
  for (auto i = (int)shuffled.size() - 1; i > 0; i--)
    std::swap(shuffled[i], shuffled[std::min((int)(rand1f(rng) * (i + 1)), i)]);
  auto a = make_sdf_tape(blob_program(centres, order, false));
  auto b = make_sdf_tape(blob_program(centres, shuffled, false));
  REQUIRE(a.ssa.size() == b.ssa.size());
  for (size_t i = 0; i < a.ssa.size(); i++) {
    CHECK(a.ssa[i].op == b.ssa[i].op);
    CHECK(a.ssa[i].a == b.ssa[i].a);
    CHECK(a.ssa[i].b == b.ssa[i].b);
    CHECK(a.ssa[i].param == b.ssa[i].param);
  }
  REQUIRE(a.frames.size() == centres.size());
  REQUIRE(b.frames.size() == centres.size());
  for (size_t i = 0; i < a.frames.size(); i++) {
    CHECK(a.frames[i].o == b.frames[i].o);
    CHECK(a.nodes[i].frame == b.nodes[i].frame);
  }
  // Consecutive operands are neighbours: a Morton walk of the lattice moves
  // one step (0.5) most of the time, never across the whole lattice.
  auto steps = 0;
  for (size_t i = 1; i < a.frames.size(); i++)
    steps += length(a.frames[i].o - a.frames[i - 1].o) <= 0.5f + 1e-5f;
  CHECK(steps >= (int)a.frames.size() / 2);
  for (auto k = 0; k < 50; k++) {
    auto p = vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} * 3.0f;
    CHECK(eval_sdf(a, p) == eval_sdf(b, p));
  }
}

TEST_CASE("sdf tape: groups nested too deep are refused") {
  // Each group's first operand (the one needing most registers) is a
  // balanced union of 16 spheres, its second the group of another blend
  // below it: the accumulators of 20 groups are open at once.
  auto program = sdf_program{};
  auto sphere  = sdf_node{};
  sphere.type  = sdf_type::sphere;
  auto inner   = add_node(program, sphere);
  for (auto level = 0; level < 20; level++) {
    auto spheres = std::vector<int>{};
    for (auto i = 0; i < 16; i++) spheres.push_back(add_node(program, sphere));
    auto hard = sdf_node{};
    hard.type = sdf_type::op_union;
    auto big  = fold_sdf_operands(program, spheres, hard);
    auto op   = sdf_node{};
    op.type   = sdf_type::op_smooth_union;
    op.blend  = 0.1f + 0.01f * level;
    inner =
        fold_sdf_operands(program, {big, inner, add_node(program, sphere)}, op);
  }
  CHECK_THROWS_WITH_AS(make_sdf_tape(program),
      doctest::Contains("smooth union groups"), io_error);
}

// Fill the stack below the caller with `value`: the registers of the
// caller's next evaluation lie there, left uninitialised (sdf_scratch).
[[gnu::noinline]] static void poison_stack(float value) {
  volatile float junk[1 << 14];
  for (auto& x : junk) x = value;
}

// The same bits (NaN equals NaN).
template <class T>
static bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

// Every evaluation type's result at p (and over a box about it).
struct tape_results {
  float             value    = 0;
  dual<float>       gradient = {};
  dual<float, 1>    slope    = {};
  interval          range    = {};
  dual<interval>    box      = {};
  dual<interval, 1> segment  = {};
};
static tape_results eval_every_way(const sdf_tape& tape, vec3f p) {
  auto begin = tape.clauses.data(), end = begin + tape.clauses.size();
  auto box = bbox3f{p - 0.05f, p + 0.05f};
  auto dir = normalize(vec3f{0.3f, -0.5f, 0.8f});
  return {eval_sdf(tape, p), eval_sdf_dual(tape, p),
      eval_sdf_slope(tape, begin, end, p, dir), eval_sdf_interval(tape, box),
      eval_sdf_dual(tape, box), eval_sdf_slope(tape, begin, end, box, dir)};
}

TEST_CASE("sdf tape: an evaluation reads only registers it wrote") {
  // The registers start as whatever the stack held: a clause that read one
  // before writing it would give other bits under other garbage.
  auto programs = std::vector<sdf_program>{};
  auto rng      = make_rng(41);
  auto centres  = std::vector<vec3f>{};
  for (auto i = 0; i < 6; i++)
    centres.push_back({uniform(rng, -0.6f, 0.6f), uniform(rng, -0.6f, 0.6f),
        uniform(rng, -0.6f, 0.6f)});
  programs.push_back(blob_program(centres, {0, 1, 2, 3, 4, 5}, false));
  for (auto type : {sdf_type::op_twist, sdf_type::op_bend, sdf_type::op_repeat,
           sdf_type::op_elongate, sdf_type::op_mirror}) {
    auto program = sdf_program{};
    add_warped_box(program, test_warp(type));
    programs.push_back(program);
  }
  for (auto text : {"max(abs(sin(5*x)*cos(5*y) + tan(0.3*z)) - 0.5, "
                    "sqrt(x*x + y*y + z*z) - 0.8)",
           "exp(-x) + log(abs(y) + 1) - atan2(y, x) + asin(clamp(z, -1, 1)) + "
           "acos(clamp(x, -1, 1)) + atan(y) - 2",
           "floor(3*x) + ceil(y) + round(z) + mod(x, 0.3) - mix(x, y, 0.25) + "
           "square(z) + min(x, y)^2 - 1 / (1 + x*x)"}) {
    auto program = sdf_program{};
    parse_sdf_expression(program, text);
    programs.push_back(program);
  }
  for (auto& program : programs) {
    auto tape = make_sdf_tape(program);
    for (auto k = 0; k < 20; k++) {
      auto p = vec3f{uniform(rng, -1.5f, 1.5f), uniform(rng, -1.5f, 1.5f),
          uniform(rng, -1.5f, 1.5f)};
      poison_stack(flt_nan);
      auto a = eval_every_way(tape, p);
      poison_stack(-7.5f);
      auto b = eval_every_way(tape, p);
      INFO("program ", &program - programs.data(), " at ", p.x, " ", p.y, " ",
          p.z);
      CHECK(same_bits(a.value, b.value));
      CHECK(same_bits(a.gradient, b.gradient));
      CHECK(same_bits(a.slope, b.slope));
      CHECK(same_bits(a.range, b.range));
      CHECK(same_bits(a.box, b.box));
      CHECK(same_bits(a.segment, b.segment));
    }
  }
}

}  // namespace implicit
