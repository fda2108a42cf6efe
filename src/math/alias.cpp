// # implicit: alias tables (implementation)

#include "alias.h"

#include <cmath>

namespace implicit {

alias_table make_alias_table(const std::vector<float>& weights) {
  auto table  = alias_table{};
  auto n      = weights.size();
  auto scaled = std::vector<double>(n, 0.0);
  for (size_t i = 0; i < n; i++) {
    auto w = weights[i];
    if (std::isfinite(w) && w > 0) {
      scaled[i] = w;
      table.total += w;
    }
  }
  if (!(table.total > 0)) return table;
  // Scale so that the mean bucket holds 1, then let every bucket under 1
  // borrow the rest from one over 1 (Vose): each bucket ends exactly full.
  for (auto& s : scaled) s *= (double)n / table.total;
  table.entries.resize(n);
  auto small = std::vector<int>{}, large = std::vector<int>{};
  small.reserve(n);
  large.reserve(n);
  for (size_t i = 0; i < n; i++)
    (scaled[i] < 1 ? small : large).push_back((int)i);
  while (!small.empty() && !large.empty()) {
    auto s = small.back(), l = large.back();
    small.pop_back();
    table.entries[s] = {(float)scaled[s], l};
    scaled[l] -= 1 - scaled[s];
    if (scaled[l] < 1) {
      large.pop_back();
      small.push_back(l);
    }
  }
  // What is left is full up to rounding.
  for (auto i : large) table.entries[i] = {1, i};
  for (auto i : small) table.entries[i] = {1, i};
  return table;
}

}  // namespace implicit
