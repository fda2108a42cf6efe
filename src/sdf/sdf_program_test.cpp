// Tests for SDF primitives and programs: closed forms at known points,
// bounds, Lipschitz bounds, gradients and exact intersections.

#include "sdf_program.h"

#include <doctest/doctest.h>

#include "../math/random.h"
#include "sdf_primitives.h"
#include "sdf_tape.h"

using namespace implicit;

static sdf_node make_node(sdf_type type) {
  auto node = sdf_node{};
  node.type = type;
  return node;
}

TEST_CASE("sdf primitives: seed types at known points") {
  // box: full size, corner at the origin.
  auto box = make_node(sdf_type::box);
  box.size = {2, 1, 4};
  CHECK(eval_primitive(box, {1, 0.5f, 2}) == doctest::Approx(-0.5f));
  CHECK(eval_primitive(box, {3, 0.5f, 2}) == doctest::Approx(1.0f));
  CHECK(eval_primitive(box, {-3, -4, 2}) == doctest::Approx(5.0f));  // 3-4-5
  CHECK(eval_primitive(box, {2, 1, 4}) == doctest::Approx(0.0f));
  // bbox: half sizes centred, bars of width t flush with the box faces.
  auto frame      = make_node(sdf_type::bbox);
  frame.size      = {1, 1, 1};
  frame.thickness = 0.1f;
  CHECK(
      eval_primitive(frame, {1, 1, 0}) == doctest::Approx(0.0f));  // outer edge
  CHECK(eval_primitive(frame, {0.95f, 0.95f, 0}) ==
        doctest::Approx(-0.05f));  // in a bar
  CHECK(eval_primitive(frame, {0, 0, 0}) ==
        doctest::Approx(std::sqrt(2.0f) * 0.8f));
  CHECK(eval_primitive(frame, {1, 1, 2}) ==
        doctest::Approx(1.0f));  // beyond a corner
  // sphere.
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 0.5f;
  CHECK(eval_primitive(sphere, {0, 0, 0}) == doctest::Approx(-0.5f));
  CHECK(eval_primitive(sphere, {0, 3, 4}) == doctest::Approx(4.5f));
  // torus about y: ring 1, tube 0.25.
  auto torus    = make_node(sdf_type::torus);
  torus.radius  = 1;
  torus.radius2 = 0.25f;
  CHECK(eval_primitive(torus, {1, 0, 0}) == doctest::Approx(-0.25f));
  CHECK(eval_primitive(torus, {0, 0, 0}) == doctest::Approx(0.75f));
  CHECK(eval_primitive(torus, {0, 0, 1.25f}) == doctest::Approx(0.0f));
  CHECK(eval_primitive(torus, {1, 1, 0}) == doctest::Approx(0.75f));
  // capped cone: half height 1, bottom radius 1, top radius 0.5.
  auto cone    = make_node(sdf_type::capped_cone);
  cone.height  = 1;
  cone.radius  = 1;
  cone.radius2 = 0.5f;
  CHECK(eval_primitive(cone, {0, 2, 0}) ==
        doctest::Approx(1.0f));  // above the top cap
  CHECK(eval_primitive(cone, {0, -1.5f, 0}) ==
        doctest::Approx(0.5f));  // below the bottom
  CHECK(eval_primitive(cone, {0, 0, 0}) ==
        doctest::Approx(-0.727607f).epsilon(1e-4));
  CHECK(eval_primitive(cone, {0.75f, 0, 0}) ==
        doctest::Approx(0.0f).epsilon(1e-5));
  // plane y = 0.
  auto plane = make_node(sdf_type::plane);
  CHECK(eval_primitive(plane, {5, -2, 7}) == doctest::Approx(-2.0f));
}

TEST_CASE("sdf primitives: new types at known points") {
  auto capsule   = make_node(sdf_type::capsule);
  capsule.height = 1;
  capsule.radius = 0.5f;
  CHECK(eval_primitive(capsule, {0, 2, 0}) == doctest::Approx(0.5f));
  CHECK(eval_primitive(capsule, {2, 0.3f, 0}) == doctest::Approx(1.5f));
  auto cylinder   = make_node(sdf_type::cylinder);
  cylinder.height = 1;
  cylinder.radius = 0.5f;
  CHECK(eval_primitive(cylinder, {0, 0, 0}) == doctest::Approx(-0.5f));
  CHECK(eval_primitive(cylinder, {1.5f, 2, 0}) ==
        doctest::Approx(std::sqrt(2.0f)));
  auto rounded   = make_node(sdf_type::rounded_box);
  rounded.size   = {1, 1, 1};
  rounded.radius = 0.25f;
  CHECK(eval_primitive(rounded, {2, 0, 0}) == doctest::Approx(1.0f));
  CHECK(eval_primitive(rounded, {1, 1, 1}) ==
        doctest::Approx(std::sqrt(3.0f) * 0.25f - 0.25f));
  auto ellipsoid = make_node(sdf_type::ellipsoid);
  ellipsoid.size = {2, 1, 1};
  CHECK(eval_primitive(ellipsoid, {2, 0, 0}) == doctest::Approx(0.0f));
  CHECK(eval_primitive(ellipsoid, {0, 1, 0}) == doctest::Approx(0.0f));
  CHECK(eval_primitive(ellipsoid, {0, 3, 0}) == doctest::Approx(2.0f));
  auto octahedron   = make_node(sdf_type::octahedron);
  octahedron.radius = 1;
  CHECK(eval_primitive(octahedron, {2, 0, 0}) == doctest::Approx(1.0f));
  CHECK(eval_primitive(octahedron, {0, 0, 0}) ==
        doctest::Approx(-1 / std::sqrt(3.0f)));
}

// Program of two unit spheres at x = -0.5 and x = +0.5 combined by `op`.
static sdf_program two_spheres(sdf_type op, float blend = 0) {
  auto program  = sdf_program{};
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 1;
  auto a        = add_transform(program, add_node(program, sphere),
             {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5f, 0, 0}});
  auto b        = add_transform(program, add_node(program, sphere),
             {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.5f, 0, 0}});
  auto node     = make_node(op);
  node.left     = a;
  node.right    = b;
  node.blend    = blend;
  add_node(program, node);
  return program;
}

TEST_CASE("sdf programs: operators") {
  // Sphere a is centred at x = -0.5 (child_from_parent adds 0.5), b at +0.5.
  auto u = make_sdf_tape(two_spheres(sdf_type::op_union));
  CHECK(eval_sdf(u, {2.5f, 0, 0}) == doctest::Approx(1.0f));
  CHECK(eval_sdf(u, {-2.5f, 0, 0}) == doctest::Approx(1.0f));
  auto i = make_sdf_tape(two_spheres(sdf_type::op_intersection));
  CHECK(eval_sdf(i, {0, 0, 0}) == doctest::Approx(-0.5f));
  CHECK(eval_sdf(i, {1.5f, 0, 0}) == doctest::Approx(1.0f));
  auto s = make_sdf_tape(two_spheres(sdf_type::op_subtraction));  // a - b
  CHECK(eval_sdf(s, {-1.2f, 0, 0}) == doctest::Approx(-0.3f));
  CHECK(eval_sdf(s, {0, 0, 0}) == doctest::Approx(0.5f));
  // Smooth union is below the union by at most blend/4, exactly where the
  // two distances are equal.
  auto su = make_sdf_tape(two_spheres(sdf_type::op_smooth_union, 0.4f));
  CHECK(eval_sdf(su, {0, 2, 0}) ==
        doctest::Approx(eval_sdf(u, {0, 2, 0}) - 0.1f));
  CHECK(eval_sdf(su, {3, 0, 0}) == doctest::Approx(eval_sdf(u, {3, 0, 0})));
  // Round and onion.
  auto program  = sdf_program{};
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 1;
  auto round    = make_node(sdf_type::op_round);
  round.left    = add_node(program, sphere);
  round.radius  = 0.5f;
  add_node(program, round);
  CHECK(eval_sdf(make_sdf_tape(program), {3, 0, 0}) == doctest::Approx(1.5f));
  auto onion      = make_node(sdf_type::op_onion);
  onion.left      = root_node(program);
  onion.thickness = 0.1f;
  add_node(program, onion);
  auto tape = make_sdf_tape(program);
  CHECK(eval_sdf(tape, {0, 0, 0}) == doctest::Approx(1.4f));
  CHECK(eval_sdf(tape, {1.5f, 0, 0}) == doctest::Approx(-0.1f));
}

TEST_CASE("sdf programs: bounds contain the surface and are tight") {
  auto u   = two_spheres(sdf_type::op_union);
  auto box = sdf_bounds(u);
  CHECK(box.min.x == doctest::Approx(-1.5f));
  CHECK(box.max.x == doctest::Approx(1.5f));
  CHECK(box.max.y == doctest::Approx(1.0f));
  auto su = sdf_bounds(two_spheres(sdf_type::op_smooth_union, 0.4f));
  CHECK(su.max.x == doctest::Approx(1.6f));
  auto in = sdf_bounds(two_spheres(sdf_type::op_intersection));
  CHECK(in.min.x == doctest::Approx(-0.5f));
  CHECK(in.max.x == doctest::Approx(0.5f));
  // Random points outside the bounds of each primitive are outside it.
  auto rng = make_rng(7);
  for (auto type :
      {sdf_type::box, sdf_type::bbox, sdf_type::sphere, sdf_type::torus,
          sdf_type::capped_cone, sdf_type::capsule, sdf_type::cylinder,
          sdf_type::rounded_box, sdf_type::ellipsoid, sdf_type::octahedron}) {
    auto node      = make_node(type);
    node.size      = {0.3f, 0.5f, 0.7f};
    node.radius    = 0.25f;
    node.radius2   = 0.1f;
    node.height    = 0.6f;
    node.thickness = 0.05f;
    auto program   = make_primitive_program(node);
    auto bounds    = sdf_bounds(program);
    auto tape      = make_sdf_tape(program);
    for (auto k = 0; k < 2000; k++) {
      auto p = vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} * 4 - 2;
      if (inside(bounds, p)) continue;
      CHECK(eval_sdf(tape, p) > 0);
    }
  }
}

TEST_CASE("sdf programs: Lipschitz bound holds on random pairs") {
  auto rng       = make_rng(11);
  auto programs  = std::vector<sdf_program>{two_spheres(sdf_type::op_union),
       two_spheres(sdf_type::op_smooth_union, 0.5f),
       two_spheres(sdf_type::op_smooth_subtraction, 0.3f)};
  auto ellipsoid = make_node(sdf_type::ellipsoid);
  ellipsoid.size = {1, 0.25f, 0.5f};
  programs.push_back(make_primitive_program(ellipsoid));
  for (auto& program : programs) {
    // An infinite bound would pass the slope check below: it must be the
    // finite factor of a distance program.
    auto lipschitz = sdf_lipschitz(program);
    REQUIRE(std::isfinite(lipschitz));
    REQUIRE(lipschitz >= 1);
    auto tape = make_sdf_tape(program);
    for (auto k = 0; k < 5000; k++) {
      auto p = vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} * 6 - 3;
      auto q = p + (vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} - 0.5f) * 0.2f;
      auto slope =
          std::abs(eval_sdf(tape, p) - eval_sdf(tape, q)) / distance(p, q);
      CHECK(slope <= lipschitz * 1.001f + 1e-4f);
    }
  }
}

TEST_CASE("sdf programs: gradients") {
  // Analytic box gradient on a box thinner than any finite-difference step.
  auto box  = make_node(sdf_type::box);
  box.size  = {2, 1e-5f, 2};
  auto tape = make_sdf_tape(make_primitive_program(box));
  auto g    = eval_sdf_gradient(tape, {1, 1e-5f, 1}, 1e-3f);
  CHECK(g.y == doctest::Approx(1.0f));
  g = eval_sdf_gradient(tape, {1, -1e-6f, 1}, 1e-3f);
  CHECK(g.y == doctest::Approx(-1.0f));
  // Finite differences on a capped cone agree with the direction to the axis
  // on its side.
  auto cone    = make_node(sdf_type::capped_cone);
  cone.height  = 1;
  cone.radius  = 1;
  cone.radius2 = 1;  // a cylinder
  auto cg      = eval_sdf_gradient(
           make_sdf_tape(make_primitive_program(cone)), {1, 0, 0}, 1e-4f);
  CHECK(cg.x == doctest::Approx(1.0f).epsilon(1e-3));
  // Torus analytic gradient points away from the ring.
  auto torus    = make_node(sdf_type::torus);
  torus.radius  = 1;
  torus.radius2 = 0.25f;
  auto tg       = eval_sdf_gradient(
            make_sdf_tape(make_primitive_program(torus)), {0, 0.25f, 1}, 1e-4f);
  CHECK(tg.y == doctest::Approx(1.0f));
}

TEST_CASE("sdf programs: exact capped cone matches the sign of its SDF") {
  // Frustum, pointed cone, cylinder and an upside-down frustum; rays from
  // around and inside toward the solid, against a dense march of the sign.
  auto rng = make_rng(11);
  for (auto radii : {vec2f{0.1f, 0.02f}, vec2f{0.3f, 0}, vec2f{0.2f, 0.2f},
           vec2f{0, 0.25f}}) {
    auto cone    = make_node(sdf_type::capped_cone);
    cone.height  = 0.1f;
    cone.radius  = radii.x;
    cone.radius2 = radii.y;
    REQUIRE(has_exact_intersection(make_primitive_program(cone)));
    auto inside_solid = [&](vec3f p) { return eval_primitive(cone, p) < 0; };
    auto hits = 0, agreed = 0;
    for (auto n = 0; n < 400; n++) {
      auto o = vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} * 1.2f -
               vec3f{0.6f, 0.6f, 0.6f};
      if (n % 4 == 0) o = o * 0.1f;  // often inside
      auto target =
          vec3f{rand1f(rng) - 0.5f, rand1f(rng) - 0.5f, rand1f(rng) - 0.5f} *
          0.6f;
      auto ray =
          ray3f{o, normalize(target - o) * (0.5f + rand1f(rng)), 0, flt_max};
      auto hit = false;
      auto t   = 0.0f;
      REQUIRE(intersect_sdf_exact(cone, ray, hit, t));
      // Reference: the first change of sign, sampled every 1e-4.
      auto step    = 1e-4f / length(ray.d);
      auto start   = inside_solid(ray.o);
      auto ref_hit = false;
      auto ref_t   = 0.0f;
      for (auto s = step; s < 2 / length(ray.d) && !ref_hit; s += step) {
        if (inside_solid(ray_point(ray, s)) != start) {
          ref_hit = true;
          ref_t   = s;
        }
      }
      INFO(radii.x, " ", radii.y, " ray ", n);
      // A graze thinner than the sampling may be found by the exact one.
      if (ref_hit) {
        REQUIRE(hit);
        CHECK(std::abs(t - ref_t) <= 2 * step);
      }
      if (hit) {
        hits++;
        CHECK(std::abs(eval_primitive(cone, ray_point(ray, t))) < 1e-5f);
        agreed += ref_hit;
      }
    }
    CHECK(hits > 100);
    CHECK(agreed >= hits - 2);
  }
  // Within [tmin, tmax] only: a ray from outside with tmax before the cone,
  // and the exit of one starting inside.
  auto cone    = make_node(sdf_type::capped_cone);
  cone.height  = 1;
  cone.radius  = 1;
  cone.radius2 = 0.5f;
  auto hit     = false;
  auto t       = 0.0f;
  intersect_sdf_exact(cone, {{0, 0, -5}, {0, 0, 1}, 0, 4}, hit, t);
  CHECK(!hit);
  intersect_sdf_exact(cone, {{0, 0, -5}, {0, 0, 1}, 0, flt_max}, hit, t);
  CHECK(hit);
  CHECK(t == doctest::Approx(4.25f));  // radius 0.75 at y = 0
  intersect_sdf_exact(cone, {{0, 0, 0}, {0, 1, 0}, 0, flt_max}, hit, t);
  CHECK(hit);
  CHECK(t == doctest::Approx(1.0f));  // the top cap
}

TEST_CASE("sdf programs: exact intersections") {
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 1;
  auto& program = sphere;
  auto  hit     = false;
  auto  t       = 0.0f;
  REQUIRE(intersect_sdf_exact(
      program, {{0, 0, -5}, {0, 0, 1}, 0, flt_max}, hit, t));
  CHECK(hit);
  CHECK(t == doctest::Approx(4.0f));
  // From inside: the exit.
  intersect_sdf_exact(program, {{0, 0, 0}, {0, 0, 1}, 0, flt_max}, hit, t);
  CHECK(hit);
  CHECK(t == doctest::Approx(1.0f));
  // Non-unit direction keeps t's meaning.
  intersect_sdf_exact(program, {{0, 0, -5}, {0, 0, 2}, 0, flt_max}, hit, t);
  CHECK(t == doctest::Approx(2.0f));
  // Miss, and a hit beyond tmax.
  intersect_sdf_exact(program, {{0, 1.01f, -5}, {0, 0, 1}, 0, flt_max}, hit, t);
  CHECK(!hit);
  intersect_sdf_exact(program, {{0, 0, -5}, {0, 0, 1}, 0, 3}, hit, t);
  CHECK(!hit);
  // Box with corner at origin; a ray parallel to a face inside the slab.
  auto box = make_node(sdf_type::box);
  box.size = {1, 2, 3};
  intersect_sdf_exact(box, {{-1, 1, 1}, {1, 0, 0}, 0, flt_max}, hit, t);
  CHECK(hit);
  CHECK(t == doctest::Approx(1.0f));
  intersect_sdf_exact(box, {{-1, 2.5f, 1}, {1, 0, 0}, 0, flt_max}, hit, t);
  CHECK(!hit);
  // Plane.
  auto plane = make_node(sdf_type::plane);
  intersect_sdf_exact(plane, {{0, 2, 0}, {0, -1, 0}, 0, flt_max}, hit, t);
  CHECK(hit);
  CHECK(t == doctest::Approx(2.0f));
  intersect_sdf_exact(plane, {{0, 2, 0}, {1, 0, 0}, 0, flt_max}, hit, t);
  CHECK(!hit);
  // Not applicable to operators.
  CHECK(!has_exact_intersection(two_spheres(sdf_type::op_union)));
}
