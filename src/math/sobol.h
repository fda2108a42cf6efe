// # implicit: low-discrepancy samples
//
// Owen-scrambled Sobol points with per-dimension shuffles (Burley 2020,
// "Practical Hash-based Owen Scrambling"). Every call draws the next
// dimension of one sample of one pixel: a 1D or 2D point of the first two
// Sobol dimensions, a (0,2)-sequence, whose sample order is shuffled and whose
// values are Owen-scrambled with seeds hashed from the pixel and dimension.
// So the first 2^m samples of a pixel stratify every dimension pair the path
// draws (one point per elementary interval), dimensions are independent of
// each other ("padding"), and pixels are independent of each other: the
// estimate stays unbiased and its error falls faster than with independent
// random numbers wherever the integrand is smooth enough.
#pragma once

#include <cstdint>

#include "math.h"

namespace implicit {

// One pixel's sample: its seed, its index in the pixel, the next dimension.
struct sobol_state {
  uint32_t seed           = 0;
  uint32_t reversed_index = 0;  // the sample's index in the pixel, reversed
  uint32_t dimension      = 0;
};

// Bits in reverse order: bytes by a byte swap, then bits within bytes.
inline uint32_t reverse_bits(uint32_t x) {
  x = __builtin_bswap32(x);
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  return ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
}

// A 32-bit integer hash with good avalanche (Wellons' lowbias32).
inline uint32_t hash_uint32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

inline uint32_t hash_combine(uint32_t seed, uint32_t value) {
  return hash_uint32(seed ^ (value + 0x9e3779b9u + (seed << 6) + (seed >> 2)));
}

// Laine-Karras permutation (Vegdahl's constants): each bit of x flips by a
// hash of the seed and of the bits below it.
inline uint32_t laine_karras(uint32_t x, uint32_t seed) {
  x ^= x * 0x3d20adeau;
  x += seed;
  x *= (seed >> 16) | 1u;
  x ^= x * 0x05526c56u;
  x ^= x * 0x53a22864u;
  return x;
}

// Nested uniform (Owen) scramble of the bits of x, highest first: each bit
// flips by a hash of the bits above it.
inline uint32_t owen_scramble(uint32_t x, uint32_t seed) {
  return reverse_bits(laine_karras(reverse_bits(x), seed));
}

// The first two Sobol dimensions of `index` as 32-bit fractions: the van der
// Corput sequence and the one from the direction numbers v_0 = 2^31,
// v_{k+1} = v_k ^ (v_k >> 1), together a (0,2)-sequence in base 2.
inline uint32_t sobol_dimension0(uint32_t index) { return reverse_bits(index); }

// Dimension 1 is the XOR of the direction numbers of the index's set bits,
// linear over GF(2): per byte of the index, one table of the XORs of its 8
// direction numbers (a bit loop would mispredict on shuffled indices).
struct sobol_tables {
  uint32_t bytes[4][256] = {};
};

constexpr sobol_tables make_sobol_tables() {
  auto     tables = sobol_tables{};
  uint32_t v[32]  = {};
  v[0]            = 1u << 31;
  for (auto k = 1; k < 32; k++) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
  for (auto byte = 0; byte < 4; byte++)
    for (auto value = 0; value < 256; value++)
      for (auto bit = 0; bit < 8; bit++)
        if (value & (1 << bit)) tables.bytes[byte][value] ^= v[8 * byte + bit];
  return tables;
}

inline constexpr sobol_tables sobol_dimension1_tables = make_sobol_tables();

inline uint32_t sobol_dimension1(uint32_t index) {
  auto& t = sobol_dimension1_tables.bytes;
  return t[0][index & 255] ^ t[1][(index >> 8) & 255] ^
         t[2][(index >> 16) & 255] ^ t[3][index >> 24];
}

// 32-bit fraction to a float in [0, 1) (the top 24 bits, so never 1).
inline float fraction_to_float(uint32_t x) {
  return (float)(x >> 8) * (1.0f / 16777216.0f);
}

inline sobol_state make_sobol(uint32_t pixel_seed, uint32_t index) {
  return {pixel_seed, reverse_bits(index), 0};
}

// The next dimension's seed and shuffled sample index (the owen_scramble of
// the index, starting from the stored reversal).
inline uint32_t next_shuffled_index(sobol_state& state, uint32_t& seed) {
  seed = hash_combine(state.seed, state.dimension++);
  return reverse_bits(laine_karras(state.reversed_index, seed));
}

// Scrambled dimension 0 of a shuffled index: owen_scramble(
// sobol_dimension0(index)) with the reversals cancelled.
inline float scrambled_dimension0(uint32_t index, uint32_t seed) {
  return fraction_to_float(
      reverse_bits(laine_karras(index, hash_uint32(seed + 1))));
}

// Next dimension as one value.
inline float sample1f(sobol_state& state) {
  auto seed  = 0u;
  auto index = next_shuffled_index(state, seed);
  return scrambled_dimension0(index, seed);
}

// Next dimension as a 2D point.
inline vec2f sample2f(sobol_state& state) {
  auto seed  = 0u;
  auto index = next_shuffled_index(state, seed);
  return {scrambled_dimension0(index, seed),
      fraction_to_float(
          owen_scramble(sobol_dimension1(index), hash_uint32(seed + 2)))};
}

}  // namespace implicit
