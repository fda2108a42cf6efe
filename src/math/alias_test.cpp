// Tests for alias tables: sampled frequencies match the weights (chi-square)
// and the remapped coin number stays uniform.

#include "alias.h"

#include <doctest/doctest.h>

#include <cmath>

#include "random.h"

using namespace implicit;

namespace {

// Pearson's statistic of `counts` against the expected probabilities; bins
// with zero probability must stay empty.
double chi_square(const std::vector<int>& counts,
    const std::vector<double>& probabilities, int samples, bool& stray) {
  auto statistic = 0.0;
  stray          = false;
  for (size_t i = 0; i < counts.size(); i++) {
    auto expected = probabilities[i] * samples;
    if (expected == 0) {
      stray = stray || counts[i] != 0;
      continue;
    }
    statistic += (counts[i] - expected) * (counts[i] - expected) / expected;
  }
  return statistic;
}

}  // namespace

TEST_CASE("alias: frequencies match the weights (chi-square)") {
  // Weights over four orders of magnitude, zeros and invalid values.
  auto rng     = make_rng(17);
  auto weights = std::vector<float>(200);
  for (auto& w : weights) w = std::pow(10.0f, 4 * rand1f(rng) - 2);
  weights[3] = 0;
  weights[7] = -1;
  weights[9] = NAN;
  weights[150] *= 1000;
  auto table = make_alias_table(weights);
  REQUIRE(table.entries.size() == weights.size());
  auto total = 0.0;
  for (auto w : weights)
    if (std::isfinite(w) && w > 0) total += w;
  CHECK(table.total == doctest::Approx(total).epsilon(1e-9));
  auto probabilities = std::vector<double>(weights.size());
  for (size_t i = 0; i < weights.size(); i++)
    probabilities[i] =
        (std::isfinite(weights[i]) && weights[i] > 0) ? weights[i] / total : 0;
  auto samples = 2000000;
  auto counts  = std::vector<int>(weights.size(), 0);
  auto coins   = std::vector<int>(10, 0);
  for (auto k = 0; k < samples; k++) {
    auto reuse = rand1f(rng);
    auto index = sample_alias(table, rand1f(rng), reuse);
    REQUIRE(index >= 0);
    REQUIRE(index < (int)weights.size());
    counts[index]++;
    REQUIRE(reuse >= 0);
    REQUIRE(reuse < 1);
    coins[(int)(reuse * 10)]++;
  }
  auto stray     = false;
  auto statistic = chi_square(counts, probabilities, samples, stray);
  CHECK_FALSE(stray);
  // 196 degrees of freedom: mean 196, standard deviation 19.8, so 300 is
  // beyond 5 sigma (the seed is fixed: the test is deterministic).
  CHECK(statistic < 300);
  // The remapped number is uniform: 9 degrees of freedom, 40 is ~5 sigma.
  auto uniform = std::vector<double>(10, 0.1);
  CHECK(chi_square(coins, uniform, samples, stray) < 40);
}

TEST_CASE("alias: degenerate weight lists") {
  CHECK(make_alias_table({}).entries.empty());
  CHECK(make_alias_table({0, 0, -2}).entries.empty());
  auto one   = make_alias_table({0, 3, 0});
  auto reuse = 0.7f;
  for (auto r : {0.0f, 0.2f, 0.5f, 0.9f, 0.99999994f}) {
    reuse = 0.7f;
    CHECK(sample_alias(one, r, reuse) == 1);
  }
  // Equal weights keep the bucket and pass the number through.
  auto flat = make_alias_table({1, 1, 1, 1});
  reuse     = 0.25f;
  CHECK(sample_alias(flat, 0.6f, reuse) == 2);
  CHECK(reuse == doctest::Approx(0.25f));
}
