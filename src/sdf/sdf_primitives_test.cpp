// Tests that walk the primitive table (sdf_primitive_table.h): for every
// primitive, with random valid parameters, its box holds its zero set and its
// inside, and its Lipschitz factor bounds its slope. A new primitive is
// covered by adding its row; the loader side is in scene_io_test.cpp.

#include "sdf_primitives.h"

#include <doctest/doctest.h>

#include <cmath>
#include <set>
#include <string>

#include "../math/random.h"

using namespace implicit;

namespace {

// Every primitive type, in table order.
std::vector<sdf_type> all_primitives() {
  auto types = std::vector<sdf_type>{};
#define IMPLICIT_SDF_TEST_TYPE(id, name) types.push_back(sdf_type::id);
  IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_TEST_TYPE)
#undef IMPLICIT_SDF_TEST_TYPE
  return types;
}

// A node of `type` with random parameters in [0.05, 1] (non-negative ones
// may also be 0); false when they fail the primitive's own checks.
bool random_node(sdf_type type, rng_state& rng, sdf_node& node) {
  node      = sdf_node{};
  node.type = type;
  for (auto& param : primitive_params(type)) {
    auto value = [&] {
      if (param.range == sdf_param_range::non_negative && rand1f(rng) < 0.2f)
        return 0.0f;
      return 0.05f + 0.95f * rand1f(rng);
    };
    switch (param.field) {
      case sdf_param_field::size:
        node.size = {value(), value(), value()};
        break;
      case sdf_param_field::radius: node.radius = value(); break;
      case sdf_param_field::radius2: node.radius2 = value(); break;
      case sdf_param_field::height: node.height = value(); break;
      case sdf_param_field::thickness: node.thickness = value(); break;
    }
  }
  return check_primitive(node).key == nullptr;
}

vec3f random_point(rng_state& rng, float half) {
  return (vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} * 2 - 1) * half;
}

bool inside(const bbox3f& box, vec3f p, float tolerance) {
  for (auto a = 0; a < 3; a++)
    if (at(p, a) < at(box.min, a) - tolerance ||
        at(p, a) > at(box.max, a) + tolerance)
      return false;
  return true;
}

}  // namespace

TEST_CASE("sdf primitive table: names, parameters, operators") {
  auto types = all_primitives();
  CHECK(types.size() == (size_t)sdf_type::op_union);
  for (auto type : types) {
    CAPTURE(sdf_type_names[(int)type]);
    CHECK(is_primitive(type));
    auto keys = std::set<std::string>{};
    for (auto& param : primitive_params(type)) {
      CHECK(std::string{param.key} != "");
      CHECK(keys.insert(param.key).second);  // no key twice
      // Keys the loader reserves for every object.
      for (auto reserved : {"name", "type", "material", "frame",
               "world_from_local", "operand", "operands"})
        CHECK(std::string{param.key} != reserved);
    }
  }
  CHECK(primitive_params(sdf_type::op_union).count == 0);
  CHECK(check_primitive(sdf_node{sdf_type::op_round}).key == nullptr);
}

TEST_CASE("sdf primitive table: bounds hold the zero set and the inside") {
  auto rng = make_rng(23);
  for (auto type : all_primitives()) {
    CAPTURE(sdf_type_names[(int)type]);
    auto sets = 0;
    for (auto trial = 0; trial < 200 && sets < 20; trial++) {
      auto node = sdf_node{};
      if (!random_node(type, rng, node)) continue;
      sets++;
      auto box       = primitive_bounds(node);
      auto finite    = is_finite(box);
      auto tolerance = 1e-4f;
      auto failures  = 0;
      for (auto i = 0; i < 500; i++) {
        // Inside: every point with a value <= 0 (unbounded boxes hold only
        // their zero set, not a half space).
        auto a  = random_point(rng, 2.5f);
        auto fa = eval_primitive(node, a);
        if (!std::isfinite(fa)) failures++;
        if (finite && fa <= 0 && !inside(box, a, tolerance)) failures++;
        // Zero set: bisect a segment whose ends have opposite signs.
        auto b  = random_point(rng, 2.5f);
        auto fb = eval_primitive(node, b);
        if ((fa < 0) == (fb < 0)) continue;
        for (auto step = 0; step < 40; step++) {
          auto m  = (a + b) * 0.5f;
          auto fm = eval_primitive(node, m);
          if ((fm < 0) == (fa < 0)) {
            a = m;
          } else {
            b = m;
          }
        }
        if (!inside(box, (a + b) * 0.5f, tolerance)) failures++;
      }
      CHECK(failures == 0);
    }
    CHECK(sets == 20);
  }
}

TEST_CASE("sdf primitive table: Lipschitz factors hold on random pairs") {
  auto rng = make_rng(29);
  for (auto type : all_primitives()) {
    CAPTURE(sdf_type_names[(int)type]);
    auto sets  = 0;
    auto worst = 0.0;  // largest slope over the factor
    for (auto trial = 0; trial < 200 && sets < 20; trial++) {
      auto node = sdf_node{};
      if (!random_node(type, rng, node)) continue;
      sets++;
      auto lipschitz = (double)primitive_lipschitz(node);
      CHECK(lipschitz >= 1);
      for (auto i = 0; i < 500; i++) {
        // Far pairs and close ones (the local slope).
        auto a = random_point(rng, 2.5f);
        auto b = i % 2 ? random_point(rng, 2.5f) : a + random_point(rng, 1e-2f);
        auto distance = (double)length(a - b);
        if (distance < 1e-4) continue;
        auto change = std::abs(
            (double)eval_primitive(node, a) - (double)eval_primitive(node, b));
        // Float rounding of the values, relative to the scene's size.
        auto slope = std::max(change - 1e-5, 0.0) / distance;
        worst      = std::max(worst, slope / lipschitz);
      }
    }
    CHECK(sets == 20);
    CHECK(worst <= 1.0 + 1e-3);
  }
}
