// Tests of tapes over boxes and of derivatives: interval soundness and
// simplification as property tests on random expressions (DAGs of math
// clauses, primitives, CSG operators, transforms and domain operators),
// derivatives against central differences, Lipschitz bounds, and the cells
// of a field of an expression.

#include <doctest/doctest.h>

#include <cmath>
#include <thread>

#include "../math/random.h"
#include "sdf_expression.h"
#include "sdf_field.h"
#include "sdf_simplify.h"
#include "sdf_tape.h"

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
int pick(rng_state& rng, int count) {
  return std::min((int)(rand1f(rng) * (float)count), count - 1);
}

sdf_node make_math(sdf_type type, int left = invalidid, int right = invalidid) {
  auto node  = sdf_node{};
  node.type  = type;
  node.left  = left;
  node.right = right;
  return node;
}

// Which clauses a random expression may use.
enum class expression_kind {
  any,     // every clause, jumps and NaN included
  smooth,  // differentiable almost everywhere, no NaN, bounded slopes
};

// A random expression of about `size` nodes: each new node reads one or two
// of the last nodes made (so subexpressions are shared: a DAG), with now and
// then a primitive, or the whole so far wrapped in a transform or a domain
// operator (after which only the wrapped root and fresh coordinates are
// read, so that shared nodes stay in one space).
sdf_program random_expression(
    rng_state& rng, int size, expression_kind kind = expression_kind::any) {
  auto program = sdf_program{};
  auto pool    = std::vector<int>{};
  auto fresh   = [&]() {
    pool.clear();
    for (auto type : {sdf_type::math_x, sdf_type::math_y, sdf_type::math_z})
      pool.push_back(add_node(program, make_math(type)));
  };
  fresh();
  auto operand = [&]() {
    auto window = std::min((int)pool.size(), 6);
    return pool[pool.size() - 1 - pick(rng, window)];
  };
  auto unary =
      kind == expression_kind::smooth
          ? std::vector<sdf_type>{sdf_type::math_neg, sdf_type::math_square,
                sdf_type::math_sin, sdf_type::math_cos, sdf_type::math_atan,
                sdf_type::math_abs}
          : std::vector<sdf_type>{sdf_type::math_neg, sdf_type::math_abs,
                sdf_type::math_square, sdf_type::math_sqrt, sdf_type::math_exp,
                sdf_type::math_log, sdf_type::math_sin, sdf_type::math_cos,
                sdf_type::math_tan, sdf_type::math_asin, sdf_type::math_acos,
                sdf_type::math_atan, sdf_type::math_floor, sdf_type::math_ceil,
                sdf_type::math_round, sdf_type::math_not, sdf_type::op_round,
                sdf_type::op_onion};
  auto binary =
      kind == expression_kind::smooth
          ? std::vector<sdf_type>{sdf_type::math_add, sdf_type::math_sub,
                sdf_type::math_mul, sdf_type::math_min, sdf_type::math_max,
                sdf_type::op_union, sdf_type::op_smooth_union,
                sdf_type::op_subtraction, sdf_type::op_smooth_intersection}
          : std::vector<sdf_type>{sdf_type::math_add, sdf_type::math_sub,
                sdf_type::math_mul, sdf_type::math_div, sdf_type::math_min,
                sdf_type::math_max, sdf_type::math_atan2, sdf_type::math_mod,
                sdf_type::math_compare, sdf_type::math_and, sdf_type::math_or,
                sdf_type::op_union, sdf_type::op_smooth_union,
                sdf_type::op_subtraction, sdf_type::op_smooth_subtraction,
                sdf_type::op_intersection};
  for (auto step = 0; step < size; step++) {
    auto r = rand1f(rng);
    if (r < 0.06f) {
      // A domain operator or a transform over everything so far.
      auto node  = sdf_node{};
      auto types = std::vector<sdf_type>{sdf_type::op_twist, sdf_type::op_bend,
          sdf_type::op_repeat, sdf_type::op_elongate, sdf_type::op_mirror,
          sdf_type::op_transform};
      node.type  = types[pick(rng, (int)types.size())];
      node.value = uniform(rng, -2, 2);
      node.size  = uniform3(rng, 0, 0.8f);
      node.count = {pick(rng, 4) - 1, pick(rng, 4) - 1, pick(rng, 4) - 1};
      node.axes  = pick(rng, 8);
      node.left  = pool.back();
      auto root  = node.type == sdf_type::op_transform
                       ? add_transform(program, pool.back(),
                             frame3f{{0.8f, 0.6f, 0}, {-0.6f, 0.8f, 0},
                                {0, 0, 1.5f}, uniform3(rng, -0.5f, 0.5f)})
                       : add_node(program, node);
      fresh();
      pool.push_back(root);
    } else if (r < 0.14f) {
      auto node   = sdf_node{};
      node.type   = rand1f(rng) < 0.5f ? sdf_type::sphere : sdf_type::box;
      node.radius = uniform(rng, 0.1f, 0.6f);
      node.size   = uniform3(rng, 0.1f, 0.8f);
      pool.push_back(add_transform(program, add_node(program, node),
          frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, uniform3(rng, -1, 1)}));
    } else if (r < 0.22f) {
      auto node  = make_math(sdf_type::math_const);
      node.value = uniform(rng, -2, 2);
      pool.push_back(add_node(program, node));
    } else if (r < 0.5f) {
      auto node   = make_math(unary[pick(rng, (int)unary.size())], operand());
      node.radius = 0.1f;
      node.thickness = 0.05f;
      pool.push_back(add_node(program, node));
    } else {
      auto a = operand();
      auto node =
          make_math(binary[pick(rng, (int)binary.size())], a, operand());
      node.blend = 0.3f;
      pool.push_back(add_node(program, node));
    }
  }
  return program;
}

// A random box: centre in [-2, 2]^3, sides from 1e-3 to 3.
bbox3f random_box(rng_state& rng) {
  auto centre = uniform3(rng, -2, 2);
  auto half   = vec3f{std::exp(uniform(rng, -7, 0.4f)),
      std::exp(uniform(rng, -7, 0.4f)), std::exp(uniform(rng, -7, 0.4f))};
  return {centre - half, centre + half};
}
vec3f random_point(rng_state& rng, const bbox3f& box) {
  auto t = uniform3(rng, 0, 1);
  // Corners and faces too.
  if (rand1f(rng) < 0.1f) t = {std::round(t.x), std::round(t.y), t.z};
  // min + (max - min) t may round past max: clamp.
  return min(max(box.min + (box.max - box.min) * t, box.min), box.max);
}

// The same float, or both NaN.
bool same(float a, float b) { return a == b || (a != a && b != b); }

// Central difference of the tape along `axis` (double step sizes).
float central(const sdf_tape& tape, vec3f p, int axis, float h) {
  auto q = p, r = p;
  at(q, axis) += h;
  at(r, axis) -= h;
  return (float)(((double)eval_sdf(tape, q) - (double)eval_sdf(tape, r)) /
                 ((double)at(q, axis) - (double)at(r, axis)));
}

// A union of 16 balls of radius 0.15 about random centres in [-1, 1]^3 (a
// cell drops the far ones, so its tape shrinks level after level), its
// values scaled by 0.01 so that no cell is far enough for a constant.
sdf_program sixteen_balls() {
  auto rng   = make_rng(61);
  auto balls = sdf_program{};
  auto math  = [&](sdf_type type, int a = invalidid, int b = invalidid) {
    return add_node(balls, make_math(type, a, b));
  };
  auto number = [&](float value) {
    auto node  = make_math(sdf_type::math_const);
    node.value = value;
    return add_node(balls, node);
  };
  auto balls_root = invalidid;
  for (auto k = 0; k < 16; k++) {
    auto centre = uniform3(rng, -1, 1);
    auto dx =
        math(sdf_type::math_sub, math(sdf_type::math_x), number(centre.x));
    auto dy =
        math(sdf_type::math_sub, math(sdf_type::math_y), number(centre.y));
    auto dz =
        math(sdf_type::math_sub, math(sdf_type::math_z), number(centre.z));
    auto squared = math(sdf_type::math_add,
        math(sdf_type::math_add, math(sdf_type::math_square, dx),
            math(sdf_type::math_square, dy)),
        math(sdf_type::math_square, dz));
    auto sphere  = math(
         sdf_type::math_sub, math(sdf_type::math_sqrt, squared), number(0.15f));
    balls_root = k == 0 ? sphere : math(sdf_type::math_min, balls_root, sphere);
  }
  math(sdf_type::math_mul, balls_root, number(0.01f));
  return balls;
}

// How many split cells, and leaves of clauses, have a range of one sign.
void count_one_side(const sdf_field& tree, int& split, int& kept) {
  build_sdf_field(tree);
  split = kept = 0;
  auto stack   = std::vector<int>{0};
  while (!stack.empty()) {
    auto& cell = get_sdf_cell(tree, stack.back());
    stack.pop_back();
    auto side = cell.range.lo > 0 || cell.range.hi < 0;
    if (cell.children < 0) {
      kept += side && cell.count > 0;
      continue;
    }
    split += side;
    for (auto octant = 0; octant < 8; octant++)
      stack.push_back(cell.children + octant);
  }
}

const auto field_box = bbox3f{{-1.3f, -1.3f, -1.3f}, {1.3f, 1.3f, 1.3f}};

}  // namespace

TEST_CASE("sdf bounds: intervals hold every value in their box") {
  auto rng     = make_rng(23);
  auto checked = 0, nan_values = 0;
  for (auto trial = 0; trial < 300; trial++) {
    auto program = random_expression(rng, 8 + trial % 40);
    auto tape    = make_sdf_tape(program);
    for (auto b = 0; b < 8; b++) {
      auto box   = random_box(rng);
      auto range = eval_sdf_interval(tape, box);
      auto duals = eval_sdf_dual(tape, box);
      CHECK(range.lo <= range.hi);
      for (auto k = 0; k < 16; k++) {
        auto p     = random_point(rng, box);
        auto value = eval_sdf(tape, p);
        auto point = eval_sdf_dual(tape, p);
        INFO("trial ", trial, " box ", b, " point ", p.x, " ", p.y, " ", p.z);
        CHECK(contains(range, value));
        CHECK(contains(duals.v, value));
        CHECK(same(point.v, value));
        // Derivatives of smooth points lie in the box's derivatives.
        if (std::isfinite(value))
          for (auto i = 0; i < 3; i++) CHECK(contains(duals.d[i], point.d[i]));
        checked++;
        nan_values += std::isnan(value);
      }
    }
  }
  CHECK(checked == 300 * 8 * 16);
  CHECK(nan_values > 0);  // the NaN rule was exercised
}

TEST_CASE("sdf bounds: moved primitives are bounded over their box") {
  // Primitives that grow with each |coordinate| (or with y) are bounded by
  // their values at the box's nearest and farthest points when a map only
  // moves them; the others, and rotated ones, by the ball about the box.
  auto rng     = make_rng(7);
  auto types   = {sdf_type::sphere, sdf_type::cylinder, sdf_type::box,
        sdf_type::rounded_box, sdf_type::plane, sdf_type::torus};
  auto checked = 0;
  for (auto type : types) {
    for (auto trial = 0; trial < 40; trial++) {
      auto node    = sdf_node{};
      node.type    = type;
      node.radius  = uniform(rng, 0.05f, 0.5f);
      node.height  = uniform(rng, 0.05f, 1);
      node.size    = uniform3(rng, 0.2f, 1.5f);
      node.radius2 = uniform(rng, 0.02f, 0.05f);  // torus: the tube
      auto program = sdf_program{};
      auto shape   = add_node(program, node);
      auto offset  = uniform3(rng, -1, 1);
      auto moved   = trial % 2 == 0;
      auto rotation =
          moved ? frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, offset}
                : frame3f{{0.8f, 0.6f, 0}, {-0.6f, 0.8f, 0}, {0, 0, 1}, offset};
      add_transform(program, shape, rotation);
      auto tape = make_sdf_tape(program);
      for (auto b = 0; b < 8; b++) {
        auto box   = random_box(rng);
        auto range = eval_sdf_interval(tape, box);
        for (auto k = 0; k < 32; k++) {
          auto p = random_point(rng, box);
          INFO("type ", (int)type, " trial ", trial, " box ", b);
          CHECK(contains(range, eval_sdf(tape, p)));
          checked++;
        }
      }
    }
  }
  CHECK(checked == 6 * 40 * 8 * 32);
  // Exact ranges where the ball's are wide: a thin cylinder beside a unit
  // cube (the ball's lower end: 1 - 0.01 - 0.866 = 0.124), a sphere.
  auto exact = [](sdf_node node, vec3f offset, const bbox3f& box) {
    auto program = sdf_program{};
    add_transform(program, add_node(program, node),
        frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, offset});
    return eval_sdf_interval(make_sdf_tape(program), box);
  };
  auto cylinder   = sdf_node{};
  cylinder.type   = sdf_type::cylinder;
  cylinder.radius = 0.01f;
  cylinder.height = 0.5f;
  auto range =
      exact(cylinder, {0, 0, 0}, {{0.5f, -0.5f, -0.5f}, {1.5f, 0.5f, 0.5f}});
  CHECK(range.lo == doctest::Approx(0.49f).epsilon(1e-3));
  CHECK(
      range.hi == doctest::Approx(std::sqrt(1.5f * 1.5f + 0.5f * 0.5f) - 0.01f)
                      .epsilon(1e-3));
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.5f;
  range         = exact(sphere, {-1, 0, 0}, {{2, 0, 0}, {3, 1, 1}});
  CHECK(range.lo == doctest::Approx(0.5f).epsilon(1e-3));
  CHECK(range.hi == doctest::Approx(std::sqrt(6.0f) - 0.5f).epsilon(1e-3));
}

// Spheres of radius 0.2 every 1 along x, `count` copies each side (< 0:
// all).
sdf_program repeated_spheres(int count) {
  auto program  = sdf_program{};
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.2f;
  auto repeat   = sdf_node{};
  repeat.type   = sdf_type::op_repeat;
  repeat.size   = {1, 0, 0};
  repeat.count  = {count, -1, -1};
  repeat.left   = add_node(program, sphere);
  add_node(program, repeat);
  return program;
}

TEST_CASE("sdf bounds: edge cases of intervals") {
  auto program = sdf_program{};
  auto x       = add_node(program, make_math(sdf_type::math_x));
  auto y       = add_node(program, make_math(sdf_type::math_y));
  auto tape_of = [&](sdf_type type, bool two) {
    auto p = program;
    add_node(p, make_math(type, x, two ? y : invalidid));
    return make_sdf_tape(p);
  };
  auto box = [](float x0, float x1, float y0 = 1, float y1 = 2) {
    return bbox3f{{x0, y0, 0}, {x1, y1, 0}};
  };
  // 0 in a divisor, domain edges: entire or the right one-sided range.
  CHECK(is_entire(eval_sdf_interval(
      tape_of(sdf_type::math_div, true), bbox3f{{1, -1, 0}, {2, 1, 0}})));
  CHECK(is_entire(
      eval_sdf_interval(tape_of(sdf_type::math_sqrt, false), box(-1e-6f, 1))));
  auto root = eval_sdf_interval(tape_of(sdf_type::math_sqrt, false), box(0, 4));
  CHECK(root.lo <= 0);
  CHECK(root.hi >= 2);
  CHECK(root.hi < 2.001f);
  CHECK(is_entire(
      eval_sdf_interval(tape_of(sdf_type::math_log, false), box(-1, 1))));
  CHECK(eval_sdf_interval(tape_of(sdf_type::math_log, false), box(0, 1)).lo ==
        -flt_inf);
  CHECK(is_entire(
      eval_sdf_interval(tape_of(sdf_type::math_asin, false), box(0, 1.01f))));
  CHECK(is_entire(
      eval_sdf_interval(tape_of(sdf_type::math_acos, false), box(-1.01f, 0))));
  // Huge arguments to sin: still within [-1, 1] and holding the values.
  auto sine  = tape_of(sdf_type::math_sin, false);
  auto large = eval_sdf_interval(sine, box(1e7f, 1e7f + 4));
  CHECK(large.lo >= -1);
  CHECK(large.hi <= 1);
  for (auto v = 1e7f; v <= 1e7f + 4; v = std::nextafter(v, flt_inf))
    CHECK(contains(large, eval_sdf(sine, {v, 1, 0})));
  // Jumps: floor and mod over a jump have no Lipschitz bound, and a finite
  // one between jumps.
  auto floor = tape_of(sdf_type::math_floor, false);
  CHECK(eval_sdf_lipschitz(floor, box(0.5f, 1.5f)) == flt_inf);
  CHECK(eval_sdf_lipschitz(floor, box(0.25f, 0.75f)) < 1e-20f);
  auto mod = tape_of(sdf_type::math_mod, true);
  CHECK(eval_sdf_lipschitz(mod, bbox3f{{2.5f, 1, 0}, {3.5f, 1, 0}}) == flt_inf);
  CHECK(eval_sdf_lipschitz(mod, bbox3f{{2.1f, 1, 0}, {2.9f, 1, 0}}) < flt_inf);
  // sqrt at 0: unbounded slope; repeat across a cell boundary: a jump.
  CHECK(eval_sdf_lipschitz(tape_of(sdf_type::math_sqrt, false), box(0, 1)) ==
        flt_inf);
  auto rtape = make_sdf_tape(repeated_spheres(-1));
  CHECK(eval_sdf_lipschitz(rtape, box(0.4f, 0.6f, 0, 0.1f)) == flt_inf);
  // Primitives bound each partial by their factor: sqrt(3) for a sphere.
  CHECK(eval_sdf_lipschitz(rtape, box(0.1f, 0.3f, 0, 0.1f)) <= 1.7321f);
  // NaN: a box where the value may be NaN gives entire, a point NaN.
  auto nan_tape = tape_of(sdf_type::math_log, false);
  CHECK(std::isnan(eval_sdf(nan_tape, {-1, 0, 0})));
  CHECK(is_entire(eval_sdf_dual(nan_tape, box(-2, -1)).d[0]));
}

TEST_CASE("sdf bounds: gradients against central differences") {
  auto rng  = make_rng(31);
  auto good = 0, total = 0;
  for (auto trial = 0; trial < 200; trial++) {
    auto program =
        random_expression(rng, 6 + trial % 20, expression_kind::smooth);
    auto tape = make_sdf_tape(program);
    for (auto k = 0; k < 20; k++) {
      auto p     = uniform3(rng, -1.5f, 1.5f);
      auto d     = eval_sdf_dual(tape, p);
      auto scale = 1 + std::abs(d.v);
      if (!std::isfinite(d.v) || scale > 1e4f) continue;
      // Kinks (abs, min, max, hard CSG) make some points disagree: count.
      auto agree = true;
      for (auto axis = 0; axis < 3; axis++) {
        auto c1 = central(tape, p, axis, 1e-3f);
        auto c2 = central(tape, p, axis, 5e-4f);
        if (std::abs(c1 - c2) > 1e-2f * (1 + std::abs(c1))) {
          agree = true;  // a kink within the step: no reference
          break;
        }
        agree = agree && std::abs(d.d[axis] - c1) <= 2e-2f * (1 + std::abs(c1));
      }
      good += agree;
      total++;
    }
  }
  CHECK(total > 3000);
  CHECK(good >= total * 995 / 1000);
  // Each math clause alone, on a smooth argument.
  for (auto type : {sdf_type::math_sqrt, sdf_type::math_exp, sdf_type::math_log,
           sdf_type::math_sin, sdf_type::math_cos, sdf_type::math_tan,
           sdf_type::math_asin, sdf_type::math_acos, sdf_type::math_atan,
           sdf_type::math_square, sdf_type::math_div, sdf_type::math_atan2,
           sdf_type::math_mod, sdf_type::math_mul}) {
    auto program = sdf_program{};
    auto x       = add_node(program, make_math(sdf_type::math_x));
    auto y       = add_node(program, make_math(sdf_type::math_y));
    add_node(program, make_math(type, x, y));
    auto tape = make_sdf_tape(program);
    for (auto k = 0; k < 50; k++) {
      // x in (0.1, 0.9), y in (1.1, 1.9): every clause is smooth there.
      auto p = vec3f{uniform(rng, 0.1f, 0.9f), uniform(rng, 1.1f, 1.9f), 0};
      auto d = eval_sdf_dual(tape, p);
      INFO(sdf_type_names[(int)type], " at ", p.x, " ", p.y);
      for (auto axis = 0; axis < 2; axis++)
        CHECK(d.d[axis] == doctest::Approx(central(tape, p, axis, 1e-3f))
                               .epsilon(2e-3)
                               .scale(1));
    }
  }
}

TEST_CASE("sdf bounds: slopes along a direction") {
  // Forward-mode derivatives along one direction (what segment tracing
  // asks): at points the gradient's dot product with it; over boxes an
  // interval that holds the point slopes and is no wider than the partials'
  // hull projected on the direction (interval products are subdistributive).
  auto rng      = make_rng(43);
  auto enclosed = 0, tighter = 0, compared = 0;
  for (auto trial = 0; trial < 300; trial++) {
    auto program = random_expression(rng, 8 + trial % 40);
    auto tape    = make_sdf_tape(program);
    auto begin = tape.clauses.data(), end = begin + tape.clauses.size();
    for (auto b = 0; b < 4; b++) {
      auto direction = normalize(uniform3(rng, -1, 1)) * uniform(rng, 0.5f, 2);
      auto box       = random_box(rng);
      auto slope     = eval_sdf_slope(tape, begin, end, box, direction);
      auto partials  = eval_sdf_dual(tape, box);
      CHECK(same(slope.v.lo, partials.v.lo));
      CHECK(same(slope.v.hi, partials.v.hi));
      auto projected = partials.d[0] * interval{direction.x} +
                       partials.d[1] * interval{direction.y} +
                       partials.d[2] * interval{direction.z};
      if (!is_entire(projected) && projected.lo == projected.lo) {
        auto margin = 1e-5f * (mag(projected) + 1e-20f);
        CHECK(slope.d[0].lo >= projected.lo - margin);
        CHECK(slope.d[0].hi <= projected.hi + margin);
        tighter += width(slope.d[0]) < width(projected) * 0.999f;
        compared++;
      }
      for (auto k = 0; k < 8; k++) {
        auto p     = random_point(rng, box);
        auto point = eval_sdf_slope(tape, begin, end, p, direction);
        auto d     = eval_sdf_dual(tape, p);
        CHECK(same(point.v, d.v));
        auto dot_d = dot(gradient(d), direction);
        if (!std::isfinite(point.d[0]) || !std::isfinite(dot_d)) continue;
        // Rounding grows with the terms, not with their (cancelling) sum.
        auto terms = dot(abs(gradient(d)), abs(direction));
        CHECK(std::abs(point.d[0] - dot_d) <= 1e-4f * (1 + terms));
        if (is_entire(slope.d[0])) continue;
        auto slack = 1e-5f * (1 + std::abs(point.d[0]));
        CHECK(point.d[0] >= slope.d[0].lo - slack);
        CHECK(point.d[0] <= slope.d[0].hi + slack);
        enclosed++;
      }
    }
  }
  CHECK(enclosed > 2000);
  CHECK(compared > 500);
  CHECK(tighter * 10 > compared);  // narrower in about a fifth
}

TEST_CASE("sdf bounds: Lipschitz bounds hold in their boxes") {
  auto rng = make_rng(41);
  for (auto trial = 0; trial < 200; trial++) {
    auto program =
        random_expression(rng, 6 + trial % 25, expression_kind::smooth);
    auto tape  = make_sdf_tape(program);
    auto box   = random_box(rng);
    auto bound = eval_sdf_lipschitz(tape, box);
    CHECK(bound >= 0);
    if (!std::isfinite(bound)) continue;
    for (auto k = 0; k < 30; k++) {
      auto p = random_point(rng, box), q = random_point(rng, box);
      if (distance(p, q) < 1e-6f * (1 + length(p))) continue;
      auto fp = eval_sdf(tape, p), fq = eval_sdf(tape, q);
      if (!std::isfinite(fp) || !std::isfinite(fq)) continue;
      auto slope = std::abs(fp - fq) / distance(p, q);
      auto noise = 4e-7f * (std::abs(fp) + std::abs(fq)) / distance(p, q);
      CHECK(slope <= bound * 1.0001f + noise);
    }
  }
}

TEST_CASE("sdf simplify: simplified tapes equal the whole one in their box") {
  auto rng     = make_rng(53);
  auto smaller = 0, folded = 0;
  for (auto trial = 0; trial < 300; trial++) {
    auto program = random_expression(rng, 10 + trial % 60);
    auto tape    = make_sdf_tape(program);
    for (auto b = 0; b < 6; b++) {
      auto box        = random_box(rng);
      auto simplified = simplify_sdf(tape, box);
      smaller += simplified.ssa.size() < tape.ssa.size();
      folded += simplified.ssa.size() == 1;
      for (auto k = 0; k < 16; k++) {
        auto p = random_point(rng, box);
        INFO("trial ", trial, " box ", b, " point ", p.x, " ", p.y, " ", p.z);
        CHECK(same(eval_sdf(simplified, p), eval_sdf(tape, p)));
      }
    }
  }
  CHECK(smaller > 300);
  CHECK(folded > 10);
}

TEST_CASE("sdf field: cells of an expression keep their range and slope") {
  // A gyroid sheet inside a sphere: max(|gyroid| - 0.2, |p| - 1.2).
  auto program = sdf_program{};
  auto v = [&](sdf_type type) { return add_node(program, make_math(type)); };
  auto c = [&](float value) {
    auto node  = make_math(sdf_type::math_const);
    node.value = value;
    return add_node(program, node);
  };
  auto op = [&](sdf_type type, int a, int b = invalidid) {
    return add_node(program, make_math(type, a, b));
  };
  auto x    = op(sdf_type::math_mul, v(sdf_type::math_x), c(4));
  auto y    = op(sdf_type::math_mul, v(sdf_type::math_y), c(4));
  auto z    = op(sdf_type::math_mul, v(sdf_type::math_z), c(4));
  auto term = [&](int a, int b) {
    return op(sdf_type::math_mul, op(sdf_type::math_sin, a),
        op(sdf_type::math_cos, b));
  };
  auto gyroid = op(sdf_type::math_add,
      op(sdf_type::math_add, term(x, y), term(y, z)), term(z, x));
  auto sheet  = op(sdf_type::math_sub, op(sdf_type::math_abs, gyroid), c(0.2f));
  auto r2     = op(sdf_type::math_add,
          op(sdf_type::math_add, op(sdf_type::math_square, v(sdf_type::math_x)),
              op(sdf_type::math_square, v(sdf_type::math_y))),
          op(sdf_type::math_square, v(sdf_type::math_z)));
  auto ball   = op(sdf_type::math_sub, op(sdf_type::math_sqrt, r2), c(1.2f));
  op(sdf_type::math_max, sheet, ball);
  REQUIRE(!std::isfinite(sdf_lipschitz(program)));
  auto params      = sdf_field_params{};
  params.max_depth = 4;
  auto field       = make_sdf_field(program, field_box, params);
  REQUIRE((bool)field.octree);
  CHECK(!field.distance);
  auto rng    = make_rng(61);
  auto leaves = 0, finite = 0, constant = 0;
  for (auto k = 0; k < 4000; k++) {
    auto p    = uniform3(rng, -1.3f, 1.3f);
    auto box  = bbox3f{};
    auto cell = find_sdf_cell(field, p, box);
    REQUIRE(cell >= 0);
    CHECK(inside(box, p));
    auto& leaf  = get_sdf_cell(field, cell);
    auto  value = eval_sdf(field.full, p);
    CHECK(contains(leaf.range, value));
    if (leaf.count == 0) {
      constant++;
      CHECK(!contains(leaf.range, 0));
      continue;
    }
    leaves++;
    CHECK(same(eval_sdf_cell(field, cell, p), value));
    CHECK(contains(eval_sdf_cell_interval(field, cell, box), value));
    if (!std::isfinite(leaf.lipschitz)) continue;
    finite++;
    auto q = random_point(rng, box);
    if (distance(p, q) > 1e-5f)
      CHECK(std::abs(eval_sdf(field.full, q) - value) <=
            leaf.lipschitz * distance(p, q) * 1.0001f + 1e-5f);
  }
  CHECK(leaves > 100);
  CHECK(finite > 100);
  CHECK(constant > 100);
}

TEST_CASE("sdf field: cells on one side of the surface are not split") {
  // The tracer crosses such a cell without an evaluation, and its children
  // would only be more cells to walk through.
  auto balls        = sixteen_balls();
  auto params       = sdf_field_params{};
  params.leaf_nodes = 1;  // split wherever the rules allow
  params.max_depth  = 5;
  auto small        = make_sdf_field(balls, field_box, params);
  REQUIRE(!small.distance);
  auto split = 0, kept = 0;
  count_one_side(small, split, kept);
  CHECK(split == 0);
  CHECK(kept > 50);
  // A bake samples every point: there such cells split, as before.
  params.split_one_side = true;
  count_one_side(make_sdf_field(balls, field_box, params), split, kept);
  CHECK(split > 500);
}

TEST_CASE("sdf field: long tapes at the surface go one level deeper") {
  // Where the surface passes with a long tape (over 4 x leaf_nodes
  // clauses), a cell goes one level past max_depth, and no further.
  auto params       = sdf_field_params{};
  params.leaf_nodes = 4;
  params.max_depth  = 2;
  auto deeper       = make_sdf_field(sixteen_balls(), field_box, params);
  CHECK(deeper.depth == 3);
  build_sdf_field(deeper);
  auto levels = std::vector<std::pair<int, int>>{{0, 0}};
  auto counts = std::vector<int>(8, 0);
  while (!levels.empty()) {
    auto [index, level] = levels.back();
    levels.pop_back();
    auto& cell = get_sdf_cell(deeper, index);
    if (cell.children < 0) {
      counts[level]++;
      continue;
    }
    for (auto octant = 0; octant < 8; octant++)
      levels.push_back({cell.children + octant, level + 1});
  }
  CHECK(counts[3] > 0);
  CHECK(counts[4] == 0);
}

TEST_CASE("sdf bounds: where a repeat changes copy") {
  // Spheres every 1 along x, 2 copies each side, moved by 0.25: borders at
  // x = -1.25, -0.25, 0.75 and 1.75 (child x = +-0.5, +-1.5).
  auto program = repeated_spheres(2);
  add_transform(program, (int)program.nodes.size() - 1,
      frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.25f, 0, 0}});
  auto tape   = make_sdf_tape(program);
  auto border = [&](float x0, float x1) {
    return find_sdf_jump(tape, tape.clauses.data(),
        tape.clauses.data() + tape.clauses.size(), {x0, 0.3f, 0},
        {x1, 0.3f, 0});
  };
  CHECK(border(0, 1) == doctest::Approx(0.75f));
  CHECK(border(1, 0) == doctest::Approx(0.25f));
  // Two borders ahead: the first, at -0.25.
  CHECK(border(-1, 1) == doctest::Approx(0.375f));
  // Inside one copy, and past the last (the copies are clamped): none.
  CHECK(std::isnan(border(0.1f, 0.3f)));
  CHECK(std::isnan(border(3, 5)));
}

TEST_CASE("sdf bounds: where floor, round, mod and compare jump") {
  auto jump = [](const std::string& formula, vec3f p0, vec3f p1) {
    auto program = sdf_program{};
    parse_sdf_expression(program, formula);
    auto tape = make_sdf_tape(program);
    return find_sdf_jump(tape, tape.clauses.data(),
        tape.clauses.data() + tape.clauses.size(), p0, p1);
  };
  // 2x from 0.2 to 1.8 reaches 1 half way; x / 0.5 from 0.4 to 1.4 reaches
  // 1 at 0.6 of the way; round jumps at 0.5, either way; compare where x - y
  // is 0.
  CHECK(
      jump("floor(2*x)", {0.1f, 0, 0}, {0.9f, 0, 0}) == doctest::Approx(0.5f));
  CHECK(jump("ceil(x)", {-0.5f, 0, 0}, {0.5f, 0, 0}) == doctest::Approx(0.5f));
  CHECK(jump("round(x)", {0, 0, 0}, {1, 0, 0}) == doctest::Approx(0.5f));
  CHECK(jump("round(x)", {0.6f, 0, 0}, {0.4f, 0, 0}) == doctest::Approx(0.5f));
  CHECK(
      jump("mod(x, 0.5)", {0.2f, 0, 0}, {0.7f, 0, 0}) == doctest::Approx(0.6f));
  auto compare = sdf_program{};
  auto x       = add_node(compare, make_math(sdf_type::math_x));
  auto y       = add_node(compare, make_math(sdf_type::math_y));
  add_node(compare, make_math(sdf_type::math_compare, x, y));
  auto ctape = make_sdf_tape(compare);
  CHECK(find_sdf_jump(ctape, ctape.clauses.data(),
            ctape.clauses.data() + ctape.clauses.size(), {0, 1, 0},
            {2, 1, 0}) == doctest::Approx(0.5f));
  // The nearest of two: floor(3x) at x = 1/3 before floor(x) at 1.
  CHECK(jump("floor(x) + floor(3*x)", {0.1f, 0, 0}, {1.1f, 0, 0}) ==
        doctest::Approx((1 / 3.0f - 0.1f) / 1.0f));
  // No step between the ends, and no jumping clause: none.
  CHECK(std::isnan(jump("floor(2*x)", {0.1f, 0, 0}, {0.4f, 0, 0})));
  CHECK(std::isnan(jump("sin(x)", {0, 0, 0}, {9, 0, 0})));
}

TEST_CASE("sdf bounds: jumps, poles and overflow hold their values") {
  // Each clause over boxes that straddle its jumps, poles or overflow: every
  // value at a point of the box lies in the box's interval (or the interval
  // is entire).
  auto rng     = make_rng(71);
  auto program = sdf_program{};
  auto x       = add_node(program, make_math(sdf_type::math_x));
  auto y       = add_node(program, make_math(sdf_type::math_y));
  auto cases   = std::vector<std::pair<sdf_type, bbox3f>>{
        {sdf_type::math_mod, {{2.5f, -0.5f, 0}, {3.5f, 0.5f, 0}}},  // 0 divides
        {sdf_type::math_mod, {{-3.5f, 0.9f, 0}, {-2.5f, 1.1f, 0}}},
        {sdf_type::math_floor, {{-1.5f, 0, 0}, {1.5f, 0, 0}}},
        {sdf_type::math_ceil, {{-0.5f, 0, 0}, {0.5f, 0, 0}}},
        {sdf_type::math_round, {{0.25f, 0, 0}, {0.75f, 0, 0}}},
        {sdf_type::math_tan, {{1.5f, 0, 0}, {1.65f, 0, 0}}},  // pole at pi/2
        {sdf_type::math_exp, {{80, 0, 0}, {100, 0, 0}}},      // overflow
        {sdf_type::math_cos, {{3e8f, 0, 0}, {3e8f + 64, 0, 0}}},
        {sdf_type::math_tan, {{1e9f, 0, 0}, {1e9f + 64, 0, 0}}},
        {sdf_type::math_atan2, {{-1, -1, 0}, {1, 1, 0}}},  // the origin
        {sdf_type::math_div, {{-1, -1e-30f, 0}, {1, 1e-30f, 0}}},
        {sdf_type::math_log, {{0, 0, 0}, {1e-30f, 0, 0}}},
        {sdf_type::math_sqrt, {{-0.0f, 0, 0}, {1e-38f, 0, 0}}},
        {sdf_type::math_acos, {{-1, 0, 0}, {-0.999f, 0, 0}}},
  };
  for (auto& [type, box] : cases) {
    auto p   = program;
    auto two = type == sdf_type::math_mod || type == sdf_type::math_atan2 ||
               type == sdf_type::math_div;
    add_node(p, make_math(type, x, two ? y : invalidid));
    auto tape  = make_sdf_tape(p);
    auto range = eval_sdf_interval(tape, box);
    auto duals = eval_sdf_dual(tape, box);
    for (auto k = 0; k < 2000; k++) {
      auto q     = random_point(rng, box);
      auto value = eval_sdf(tape, q);
      INFO(sdf_type_names[(int)type], " at ", q.x, " ", q.y, " = ", value,
          " in [", range.lo, ", ", range.hi, "]");
      CHECK(contains(range, value));
      CHECK(contains(duals.v, value));
    }
  }
}

TEST_CASE("sdf field: built lazily by many threads, the same as built alone") {
  // One field evaluated by parallel threads in a random order, another
  // built cell by cell first: the same cells, the same floats.
  auto rng = make_rng(83);
  for (auto trial = 0; trial < 6; trial++) {
    auto program      = random_expression(rng, 60 + 20 * trial);
    auto box          = bbox3f{{-1.5f, -1.5f, -1.5f}, {1.5f, 1.5f, 1.5f}};
    auto params       = sdf_field_params{};
    params.leaf_nodes = 4;
    params.max_depth  = 4;
    auto lazy         = make_sdf_field(program, box, params);
    auto eager        = make_sdf_field(program, box, params);
    if (!lazy.octree) continue;
    build_sdf_field(eager);
    auto points = std::vector<vec3f>(20000);
    for (auto& p : points) p = random_point(rng, box);
    auto values = std::vector<float>(points.size());
    auto worker = [&](size_t start) {
      for (auto i = start; i < points.size(); i += 4)
        values[i] = eval_sdf(lazy, points[i]);
    };
    auto threads = std::vector<std::thread>{};
    for (auto t = 0; t < 4; t++) threads.emplace_back(worker, (size_t)t);
    for (auto& thread : threads) thread.join();
    for (size_t i = 0; i < points.size(); i++) {
      INFO("trial ", trial, " point ", i);
      CHECK(find_sdf_cell(lazy, points[i]) >= 0);
      CHECK(same(values[i], eval_sdf(eager, points[i])));
    }
    CHECK(sdf_field_cells_built(lazy) <= sdf_field_cells_built(eager));
  }
}

}  // namespace implicit
