// Tests for the light tree: pick probabilities are sampling frequencies
// (chi-square), sum to 1, and the traversal along a ray reports the same
// numbers.

#include "light_tree.h"

#include <doctest/doctest.h>

#include <cmath>

#include "../math/random.h"

using namespace implicit;

TEST_CASE("light tree: pick probabilities are its frequencies") {
  // 40 emitters: spheres and flat two-sided quads of assorted power.
  auto rng      = make_rng(3);
  auto emitters = std::vector<light_bounds>{};
  for (auto k = 0; k < 40; k++) {
    auto bounds   = light_bounds{};
    auto c        = vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} * 4.0f - 2.0f;
    auto r        = 0.05f + 0.2f * rand1f(rng);
    auto flat     = k % 3 == 0;
    auto half     = flat ? vec3f{r, 1e-4f, r} : vec3f{r, r, r};
    bounds.bounds = {c - half, c + half};
    bounds.reach  = {c - r * 1.8f, c + r * 1.8f};
    bounds.power  = 0.1f + 10 * rand1f(rng) * rand1f(rng);
    if (flat) {
      bounds.axis       = {0, 1, 0};
      bounds.cos_spread = 0.99f;
      bounds.two_sided  = true;
    } else {
      bounds.cos_spread = -1;
    }
    emitters.push_back(bounds);
  }
  auto tree = make_light_tree(emitters);
  REQUIRE(tree.nodes.size() == 2 * emitters.size() - 1);
  struct query {
    vec3f position, normal;
  };
  for (auto q : {query{{0, 0, 0}, {0, 0, 0}}, query{{3, 0.5f, -1}, {0, 1, 0}},
           query{{-1, 2.5f, 0}, {0, -1, 0}}}) {
    auto total = 0.0;
    for (auto k = 0; k < (int)emitters.size(); k++)
      total += light_tree_probability(tree, k, q.position, q.normal);
    CHECK(total == doctest::Approx(1.0).epsilon(1e-5));
    // Pearson's chi-square over the emitters with a chance.
    auto samples = 200000;
    auto counts  = std::vector<int>(emitters.size(), 0);
    for (auto s = 0; s < samples; s++) {
      auto pick = sample_light_tree(tree, q.position, q.normal, rand1f(rng));
      REQUIRE(pick.index >= 0);
      CHECK(pick.probability ==
            light_tree_probability(tree, pick.index, q.position, q.normal));
      counts[pick.index]++;
    }
    auto chi2 = 0.0;
    auto bins = 0;
    for (auto k = 0; k < (int)emitters.size(); k++) {
      auto expected =
          samples * light_tree_probability(tree, k, q.position, q.normal);
      if (expected <= 0) {
        CHECK(counts[k] == 0);
        continue;
      }
      chi2 += (counts[k] - expected) * (counts[k] - expected) / expected;
      bins++;
    }
    // df = bins - 1: the 99.99th percentile is below df + 4.5 sqrt(2 df) + 8.
    auto df = bins - 1.0;
    INFO("chi2 ", chi2, " df ", df);
    CHECK(chi2 < df + 4.5 * std::sqrt(2 * df) + 8);
    // The traversal along a ray reports the same probabilities, to the bit.
    auto direction = normalize(vec3f{0.3f, 0.2f, -0.9f});
    auto visited   = 0;
    visit_light_tree(tree, q.position, q.normal, direction, true,
        [&](int index, float probability) {
          visited++;
          CHECK(probability ==
                light_tree_probability(tree, index, q.position, q.normal));
          CHECK(may_reach(emitters[index].reach, q.position, direction));
        });
    // Every emitter the ray reaches (with a chance) is visited.
    auto reached = 0;
    for (auto k = 0; k < (int)emitters.size(); k++)
      if (may_reach(emitters[k].reach, q.position, direction) &&
          light_tree_probability(tree, k, q.position, q.normal) > 0)
        reached++;
    CHECK(visited == reached);
  }
}
