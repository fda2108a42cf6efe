// # implicit: alias tables
//
// O(1) sampling of an index with probability weight[i] / sum(weights)
// (Walker 1977, built with Vose's 1991 method). Binary search over a cdf
// touches log2(n) cache lines at random; an environment of 2048x1024 texels
// makes that 21 misses per sample, the alias table one.
#pragma once

#include <cstdint>
#include <vector>

#include "math.h"

namespace implicit {

// Bucket i keeps index i with probability `keep`, else gives `alias`.
struct alias_entry {
  float keep  = 1;
  int   alias = 0;
};

// The table and the sum of the weights it was built from (double, so that
// a pdf computed as weight / total matches the sampled frequencies).
struct alias_table {
  std::vector<alias_entry> entries = {};
  double                   total   = 0;
};

// Table for non-negative finite weights (others count as 0). An all-zero or
// empty list gives an empty table.
alias_table make_alias_table(const std::vector<float>& weights);

// Index drawn with one number `r` choosing the bucket and a second number
// `reuse` tossing its coin; `reuse` is then remapped to a fresh uniform
// number in [0,1), so the caller can spend it again (the fraction of r * n
// would leave too few bits to toss with when n is in the millions).
inline int sample_alias(const alias_table& table, float r, float& reuse) {
  auto size   = (int)table.entries.size();
  auto bucket = clamp((int)(r * size), 0, size - 1);
  auto entry  = table.entries[bucket];
  auto keep   = reuse < entry.keep;
  reuse = keep ? reuse / entry.keep : (reuse - entry.keep) / (1 - entry.keep);
  reuse = clamp(reuse, 0.0f, 1 - flt_eps / 2);
  return keep ? bucket : entry.alias;
}

}  // namespace implicit
