// # implicit: random numbers
//
// PCG32 (O'Neill 2014) as in Yocto/GL: small state, one generator per pixel so
// images do not depend on the thread count.
#pragma once

#include <cstdint>
#include <cstring>

#include "math.h"

namespace implicit {

struct rng_state {
  uint64_t state = 0x853c49e6748fea9bULL;
  uint64_t inc   = 0xda3e39cb94b95bdbULL;
};

// Next 32 random bits.
inline uint32_t advance_rng(rng_state& rng) {
  auto old   = rng.state;
  rng.state  = old * 6364136223846793005ULL + rng.inc;
  auto xorsh = (uint32_t)(((old >> 18u) ^ old) >> 27u);
  auto rot   = (uint32_t)(old >> 59u);
  return (xorsh >> rot) | (xorsh << ((~rot + 1u) & 31));
}

// Seed a generator; `seq` selects one of 2^63 independent streams.
inline rng_state make_rng(uint64_t seed, uint64_t seq = 1) {
  auto rng  = rng_state{};
  rng.state = 0U;
  rng.inc   = (seq << 1u) | 1u;
  advance_rng(rng);
  rng.state += seed;
  advance_rng(rng);
  return rng;
}

// Uniform integer in [0, n).
inline int rand1i(rng_state& rng, int n) {
  return n > 0 ? (int)(advance_rng(rng) % (uint32_t)n) : 0;
}

// Uniform float in [0, 1).
inline float rand1f(rng_state& rng) {
  auto bits = (advance_rng(rng) >> 9) | 0x3f800000u;
  auto f    = 0.0f;
  std::memcpy(&f, &bits, sizeof(f));
  return f - 1;
}

inline vec2f rand2f(rng_state& rng) {
  auto x = rand1f(rng);
  auto y = rand1f(rng);
  return {x, y};
}

}  // namespace implicit
