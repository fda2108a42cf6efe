// # implicit: sphere tracing
//
// One marching loop for every caller (single objects in their own space, the
// seed's whole-scene minimum), templated on the distance so that the inner
// loop has no indirect call.
//
// The march is Hart's sphere tracing (1996) with Keinert et al.'s (2014)
// over-relaxation: steps are stretched by `overrelax` while consecutive
// unbounding spheres still overlap; when they stop overlapping, the step is
// undone and relaxation is switched off. The distance is followed with the
// sign it has at the start, so rays that start inside an object (refraction)
// march to its exit. If the iteration cap is reached, the point of closest
// approach counts as a hit when it is within `fallback` thresholds: grazing
// rays then do not show the background through a surface.
#pragma once

#include "accel.h"

namespace implicit {

struct march_result {
  bool  hit         = false;
  float distance    = flt_max;
  float epsilon     = 0;
  int   evaluations = 0;
};

// March t in [t0, t1]; `distance(t)` is a signed lower bound of the world
// distance from the ray point at t to the surface.
template <typename Distance>
inline march_result sphere_trace(const Distance& distance, float t0, float t1,
    const march_params& params, float hit_min) {
  auto result      = march_result{};
  auto omega       = params.overrelax;
  auto t           = t0;
  auto step        = 0.0f;
  auto prev_radius = 0.0f;
  auto best_ratio  = flt_max;
  auto best_t      = t0;
  auto best_eps    = hit_min;
  auto side        = 0.0f;
  for (auto i = 0; i < params.max_iterations; i++) {
    // Past the end: an over-relaxed step may have jumped over a surface
    // near the end, so retry with a plain step before giving up.
    if (t > t1) {
      if (omega <= 1 || step <= 0) break;
      t     = t - step + prev_radius;
      step  = prev_radius;
      omega = 1;
      if (t > t1) break;
    }
    auto d = distance(t);
    result.evaluations++;
    if (side == 0) side = d < 0 ? -1.0f : 1.0f;
    auto signed_radius = side * d;
    auto radius        = std::abs(d);
    auto eps           = std::max(hit_min, params.hit_relative * t);
    // Over-relaxed step overshot: the two spheres do not overlap, so the
    // surface may lie in the gap. Return to a plain step from the last point.
    if (omega > 1 && radius + prev_radius < step) {
      t -= step;
      t += prev_radius;
      step        = prev_radius;
      omega       = 1;
      prev_radius = 0;
      continue;
    }
    if (radius < eps) {
      result.hit      = true;
      result.distance = t;
      result.epsilon  = eps;
      return result;
    }
    if (radius / eps < best_ratio) {
      best_ratio = radius / eps;
      best_t     = t;
      best_eps   = eps;
    }
    // A negative signed radius means we crossed the surface: step back.
    step        = signed_radius * omega;
    prev_radius = radius;
    t += step;
  }
  if (best_ratio < params.fallback && best_t <= t1) {
    result.hit      = true;
    result.distance = best_t;
    result.epsilon  = best_eps * params.fallback;
  }
  return result;
}

}  // namespace implicit
