// # implicit: tracing functions that are no distance bounds
//
// A closed-form expression (x^2 + y^2 + z^2 - 1, a tangle cube, an exp/ln
// blend) has no global Lipschitz bound the user could be trusted to give,
// and sphere tracing with a wrong one leaves holes. This march needs none:
// it walks the ray through regions (the leaf cells of the object's field, or
// its whole box in the reference mode) that each know the range of the
// function over them and a bound of its slope along the ray:
//
// - a region whose range excludes 0 holds no surface and is crossed without
//   an evaluation (the interval test of Knoll et al. 2009, "Fast Ray Tracing
//   of Arbitrary Implicit Surfaces with Interval and Affine Arithmetic");
// - in a region with a finite slope bound, the march steps by |f| over the
//   rate at which f may approach 0 there (at most its Lipschitz bound L),
//   which cannot pass a root (segment tracing, Galin et al. 2020, "Segment
//   Tracing Using Local Lipschitz Bounds": the Lipschitz bound of the
//   segment ahead, here of the region it lies in), and by at least the hit
//   threshold, evaluating the end of each such forced step; where the
//   bound is loose and those steps would creep up to the surface, a
//   bolder step whose end value, with the bound of how fast f may
//   approach 0 backwards, proves it crossed no root (segment_bold_step);
//   the bold or plain steps that would follow one another there are
//   aimed at once and evaluated in one batch (one pass of the tape over up
//   to 8 points, about 1.6 times a single value's cost), then checked in
//   order as one step at a time would be (segment_bold_batch);
// - in a region without a finite bound (a jump, sqrt at 0, a possible NaN)
//   the ray's interval is bisected with an explicit stack, nearest half
//   first, and each piece is dropped when its range excludes 0, marched when
//   its own slope bound is finite, or sampled at its end once it is shorter
//   than the hit threshold (Knoll et al.'s root isolation); pieces where the
//   value may be NaN and is NaN at both ends stop at a coarser length, so a
//   NaN region costs a fixed number of samples instead of a bisection down
//   to the threshold, while its border is still bisected; a piece across a
//   known jump (a repeat's border, a step of floor or mod) is cut there
//   instead, around a gap of the hit threshold that is only sampled;
// - a region or segment over which f moves strictly towards 0 holds at
//   most one root, so one value decides it at once: where f would reach 0
//   at its least rate (the region's bound of df/dt is signed: the octree's
//   leaves keep their gradient's hull, projected on the ray).
//
// A hit is a change of side: inside means f < 0, and NaN counts as outside,
// so NaN regions never stop a ray that starts outside. The first change is
// bracketed between the last point known to lie on the ray's starting side
// (everything before it checked) and the first point known to lie on the
// other, then refined to the root by Newton's method on the exact derivative
// along the ray, falling back to bisection whenever a Newton step leaves the
// bracket, so the reported point lies within a fraction of the hit threshold
// of the surface, on the starting side. Roots closer together than the hit
// threshold (a sliver thinner than it) may be passed, as sphere tracing
// passes them; nothing else is.
#pragma once

#include "../math/dual.h"
#include "accel.h"
#include "sphere_trace.h"

namespace implicit {

// -----------------------------------------------------------------------------
// REGIONS
// -----------------------------------------------------------------------------

// A stretch of the ray inside one region: the region's handle (what the
// function evaluates with), where the ray leaves it, the range of the values
// over it and the interval of df/dt along the ray there (entire if none).
// `local_bounds`: whether a bound over a segment ahead may pay for itself
// where the region's own slope bound steps short (segment_local_step): over
// a long stretch (the whole tape) it saves many steps; an octree leaf's own
// bound is the tape's over a small cell already, and a bound costs about 8
// values (the gyroid lattice example: 1.8x faster without them in leaves).
struct segment_region {
  int      region       = invalidid;
  float    t_exit       = 0;
  interval range        = entire_interval;
  interval derivative   = entire_interval;
  bool     local_bounds = true;
};

// Range over a piece of the ray (the box of its ends), and the interval of
// df/dt there (its sign tells which way f may move).
struct segment_bound {
  interval range      = entire_interval;
  interval derivative = entire_interval;
};

// Bound of |df/dt| from its interval (+inf if none).
inline float segment_slope(interval derivative) {
  auto slope = mag(derivative);
  return slope == slope ? slope : flt_inf;
}

// Whether a range holds one side of the surface only (no root).
inline bool segment_one_side(interval range) {
  return !is_entire(range) && (range.hi < 0 || range.lo >= 0);
}

// The function along one ray, as the march sees it (accel.cpp adapts an
// object's field; tests adapt closed forms). Any type with these members:
//   segment_region locate(float t)       the region the ray enters at t
//   float value(int region, float t)     f at the ray point t
//   void values(int region, const float* t, float* f, int count)   f at
//       `count` ray points (at most segment_batch_size) in one pass
//   vec2f value_slope(int region, float t)   f and df/dt there
//   segment_bound bound(int region, float t0, float t1)   over [t0, t1]
//   float split(int region, float t0, float t1)   a t in (t0, t1) where f
//       may jump (a repeat's border, floor, mod), to split a piece without a
//       slope bound there; NaN if none is known
// `locate` must return t_exit > t except at the end of the ray.

// -----------------------------------------------------------------------------
// MARCH
// -----------------------------------------------------------------------------

// Pieces of a region without a finite bound where the value may be NaN, and
// is NaN at both ends, stop being bisected at this fraction of the object's
// stretch of the ray (the regions of a field are many and small where the
// value may be NaN: their range never decides them).
inline constexpr float segment_nan_fraction = 1.0f / 16;
// Most pieces pending at once: bisection halves a piece per level, and a
// float interval cannot be halved more than about 280 times, but the hit
// threshold stops it long before (t * 1e-5 is 17 halvings of t).
inline constexpr int segment_stack_size = 64;
// A root is refined until its bracket is this fraction of the hit
// threshold, or a few floats wide, or after this many steps.
inline constexpr float segment_root_fraction = 1e-3f;
inline constexpr int   segment_root_steps    = 64;
// The region's slope bound is refined over a segment ahead when its step
// covers less than this fraction of the region's stretch.
inline constexpr float segment_local_fraction = 1.0f / 8;
// Most points of a batch of steps (segment_bold_batch): the width of the
// batched evaluator's narrow lanes (sdf_march_lane_count). A batch counts
// as one evaluation (one pass of the tape) in the ray's count and budget.
inline constexpr int segment_batch_size = 8;
// Evaluations per ray (points, intervals) allowed per iteration of the
// sphere-tracing cap: a region costs about as much as a sphere-tracing step.
inline constexpr int segment_evaluation_factor = 4;

// What the march has learned so far along the ray.
struct segment_state {
  bool  start_inside = false;  // side of the ray's start (f < 0)
  float last_t       = 0;      // everything before it is on the start side
  float last_f       = 0;      // f at last_t when `have_last`
  bool  have_last    = false;
  // The value checked before last_t's, where known (else NaN): how fast f
  // fell there aims the next region's first bold step.
  float before_t = flt_nan, before_f = flt_nan;
  // A proven lower bound of |f| at margin_t, on the start side (0: none):
  // what a step that crossed a region whole leaves of |f| at its end, so
  // the next region may be crossed without an evaluation.
  float margin          = 0;
  float margin_t        = 0;
  float cutoff          = flt_max;
  int   evaluations     = 0;
  int   max_evaluations = 0;
  // A bracket [lo, hi] of the first change of side, once found, and f at
  // its ends where known (else NaN).
  bool  found = false;
  float lo = 0, hi = 0;
  float f_lo = flt_nan, f_hi = flt_nan;
};

// Whether f lies inside (NaN counts as outside).
inline bool segment_inside(float f) { return f < 0; }

// Hit threshold at t along the ray.
inline float segment_epsilon(
    const march_params& params, float hit_min, float t) {
  return std::max(hit_min, params.hit_relative * t);
}

// Note a change of side first seen at `t` (its value there `f`, if known).
inline void segment_bracket(segment_state& state, float t, float f = flt_nan) {
  state.found = true;
  state.lo    = state.last_t;
  state.hi    = t;
  state.f_lo  = state.have_last ? state.last_f : flt_nan;
  state.f_hi  = f;
}

// Note that everything up to `t` lies on the start side and that |f| >=
// margin there (0: unknown).
inline void segment_skip(segment_state& state, float t, float margin) {
  state.last_t    = t;
  state.have_last = false;
  state.before_t  = flt_nan;
  state.margin    = margin;
  state.margin_t  = t;
}

// Note that f at t (on the start side) was checked with everything before.
inline void segment_advance(segment_state& state, float t, float f) {
  state.before_t  = state.have_last ? state.last_t : flt_nan;
  state.before_f  = state.last_f;
  state.last_t    = t;
  state.last_f    = f;
  state.have_last = true;
}

// Sample f at t: note a change of side (true) or advance to it (the
// value is then state.last_f).
template <typename Function>
inline bool segment_sample(
    const Function& function, int region, float t, segment_state& state) {
  auto f = function.value(region, t);
  state.evaluations++;
  if (segment_inside(f) != state.start_inside) {
    segment_bracket(state, t, f);
    return true;
  }
  segment_advance(state, t, f);
  return false;
}

// A segment of the ray ahead with its own bound of df/dt (Galin et al.'s
// local Lipschitz bound of the segment, signed), kept for every step that
// starts in it.
struct segment_local {
  float    end        = 0;                // the bound holds up to here
  interval derivative = entire_interval;  // of f along the ray there
  bool     empty      = false;            // the segment's range excludes 0
  float    length     = 0;                // of the segment
  float    next       = 0;                // length of the next one
};

// How fast f may move towards the other side of the surface over a
// segment where df/dt lies in `derivative`: its lower end when f starts
// outside (f falls to 0), its upper end inside; 0 when f cannot move that
// way, +inf when unknown (NaN).
inline float segment_approach(interval derivative, bool start_inside) {
  auto rate = start_inside ? derivative.hi : -derivative.lo;
  if (rate != rate) return flt_inf;
  return rate > 0 ? rate : 0.0f;  // never -0: |f| / -0 is -inf
}

// Whether f moves strictly towards the other side over the whole segment:
// then it crosses 0 at most once there, and the value at the segment's end
// decides whether it does.
inline bool segment_monotone(interval derivative, bool start_inside) {
  return start_inside ? derivative.lo > 0 : derivative.hi < 0;
}

// Where a decisive step (f moves towards the surface over the whole
// stretch `ahead`, with `derivative`) ends: where f would have reached 0 at
// its least rate, so the root lies before there or the stretch holds none
// (or a threshold on, past roundings of f), or at the stretch's end.
inline float segment_decisive_step(interval derivative, bool start_inside,
    float f, float ahead, float epsilon) {
  auto least = start_inside ? derivative.lo : -derivative.hi;
  return std::min(ahead, std::max(std::abs(f) / least, epsilon));
}

// A bolder step than |f| / rate where f approaches the surface slowly
// (a loose slope bound makes the march creep up to it, |f| shrinking by a
// constant factor a step): where |f| falls at the rate `fall` / `gap` seen
// over the last step (fall = f before minus f now, negated `inside`, where
// f < 0 rises), a step of s ends at |f| - fall / gap * s, which the
// bound `back` (of how fast f may approach 0 backwards) proves root-free
// back to the start's root-free |f| / rate while s < |f| (1 / rate + 1 /
// back) / (1 + fall / gap / back). A tenth short of that, and of where
// the line reaches 0 (curvature); 0 when f did not fall. Balint and
// Valasek's planar step of sphere tracing (sphere_trace.h), with the
// signed rates of a region instead of a Lipschitz constant.
inline float segment_bold_step(
    float f, float gap, float fall, float rate, float back, bool inside) {
  auto slope = (inside ? -fall : fall) / gap;
  if (!(slope > 0) || !(rate > 0) || !(back > 0)) return 0;
  auto size  = std::abs(f);
  auto along = size / slope;
  auto proof = size * (1 / rate + 1 / back) / (1 + slope / back);
  return 0.9f * std::min(along, proof);
}

// The bold steps that would follow one another from t (f there, `safe` =
// |f| / rate root-free after it) if f kept falling at the rate `slope` seen
// over the last step, evaluated in one batch (the creep near a surface was
// most of a hit's values, each a pass over the leaf's tape: a batch of 8
// costs about 1.6 of them), then checked in order as segment_bold_step's
// proof checks one: a point on the start side is kept while no root lies
// within |f| / rate after the last kept point nor within |f_k| / back
// before it; the first point on the other side brackets the root when what
// is unproven between the last kept point and it is no wider than the hit
// threshold (a plain step's bracket); the sequence ends with a step of the
// threshold once the aimed steps get shorter (where the plain march would
// step by it). Returns the points kept (the last in t, f, the one before in
// t_prev, f_prev) or, with state.found, the bracket; 0 when none was kept
// and nothing bracketed, -1 when the aim left room for one step only (the
// march takes it alone).
template <typename Function>
inline int segment_bold_batch(const Function& function, int region, float& t,
    float& f, float& t_prev, float& f_prev, float rate, float back, float reach,
    float epsilon, segment_state& state) {
  auto  inside = state.start_inside;
  auto  slope  = (inside ? -(f_prev - f) : f_prev - f) / (t - t_prev);
  float points[segment_batch_size], values[segment_batch_size];
  auto  count = 0;
  auto  at = t, size = std::abs(f);
  while (count < segment_batch_size) {
    auto bold = 0.9f * std::min(size / slope,
                           size * (1 / rate + 1 / back) / (1 + slope / back));
    auto last = !(bold > epsilon);
    auto next = at + (last ? std::max(epsilon, size / rate) : bold);
    if (!(next > at && next < reach)) break;
    points[count++] = next;
    if (last) break;
    size -= slope * bold;
    at = next;
  }
  if (count < 2) return -1;
  function.values(region, points, values, count);
  state.evaluations++;  // one pass (the cost the budget counts)
  auto kept = 0;
  for (auto k = 0; k < count; k++) {
    auto f_k = values[k], gap = points[k] - t, ahead = std::abs(f) / rate;
    if (f_k != f_k) break;
    if (segment_inside(f_k) != inside) {
      if (gap - ahead - std::abs(f_k) / rate <= epsilon) {
        segment_bracket(state, points[k], f_k);
        return kept + 1;
      }
      break;
    }
    if (!(ahead + std::abs(f_k) / back >= gap)) break;
    t_prev = t, f_prev = f;
    t = points[k], f = f_k;
    segment_advance(state, t, f);
    kept++;
  }
  return kept;
}

// Plain steps from t, the first of `step` (|f| / rate or the hit
// threshold), the next ones of the threshold (no longer than a plain step
// from there would be), where f's fall over the last step (slope, as
// segment_bold_batch) says the surface lies more than one step ahead: up to
// segment_batch_size of them in one batch, each point's side checked in
// order as segment_sample checks it (the first change of side brackets, as
// a plain step would). Where the bold step's proof is short of the
// threshold (a slope far below the region's bound), these steps were over a
// sixth of a hit's values. Returns the points taken (0: the march steps
// alone).
template <typename Function>
inline int segment_plain_batch(const Function& function, int region, float& t,
    float& f, float& t_prev, float& f_prev, float step, float epsilon, float b,
    segment_state& state) {
  auto inside = state.start_inside;
  auto slope  = (inside ? -(f_prev - f) : f_prev - f) / (t - t_prev);
  auto along  = std::abs(f) / slope - step;
  if (!(along > 0.5f * epsilon)) return 0;
  auto  count = std::min(segment_batch_size, (int)(along / epsilon) + 2);
  float points[segment_batch_size], values[segment_batch_size];
  for (auto k = 0; k < count; k++) {
    points[k] = std::min(t + step + epsilon * (float)k, b);
    if (!(points[k] > (k == 0 ? t : points[k - 1]))) count = k;
  }
  if (count < 2) return 0;
  function.values(region, points, values, count);
  state.evaluations++;  // one pass (the cost the budget counts)
  for (auto k = 0; k < count; k++) {
    if (segment_inside(values[k]) != inside) {
      segment_bracket(state, points[k], values[k]);
      return k + 1;
    }
    t_prev = t, f_prev = f;
    t = points[k], f = values[k];
    segment_advance(state, t, f);
  }
  return count;
}

// Step from t where the region's slope bound allows `safe`: when that
// covers little of the stretch to b, the bound over a segment ahead may
// allow more. A segment serves the steps that start in it while they stay a
// fair part of it (a long segment's bound is loose where the steps get
// short, near a surface); the next one is twice as long when a step could
// cross it whole, else four times the last step (or the region's). Within a
// segment, f cannot reach 0 before |f| over its approach rate (the signed
// bound: a slope away from the surface does not shorten the step); a
// segment whose range excludes 0 is crossed whole. Where f moves strictly
// towards the surface over the whole segment the step is `decisive`
// (segment_decisive_step): no root-free step, but one whose end value
// tells whether it passed the (single) root, so the march brackets it at
// once instead of creeping up to it (Newton's method refines it).
template <typename Function>
inline float segment_local_step(const Function& function, int region, float t,
    float b, float f, float safe, float epsilon, segment_local& local,
    segment_state& state, bool& decisive) {
  decisive = false;
  if (safe >= (b - t) * segment_local_fraction) return safe;
  auto step = 0.0f, ahead = local.end - t;
  for (auto fresh = false; !fresh;) {
    fresh = !(t < local.end);
    if (fresh) {
      local.length = std::min(b - t, std::max(4 * safe, local.next));
      auto bound   = function.bound(region, t, t + local.length);
      state.evaluations++;
      auto range       = bound.range;
      local.end        = t + local.length;
      local.empty      = segment_one_side(range);
      local.derivative = bound.derivative;
      ahead            = local.length;
    }
    auto rate = segment_approach(local.derivative, state.start_inside);
    step      = local.empty || rate == 0 ? ahead : std::abs(f) / rate;
    if (!(step >= 0)) step = 0;  // an unknown slope: inf / inf
    if (!local.empty && f == f &&
        segment_monotone(local.derivative, state.start_inside) &&
        step < ahead) {
      decisive = true;
      return segment_decisive_step(
          local.derivative, state.start_inside, f, ahead, epsilon);
    }
    local.next = step >= ahead ? 2 * local.length : 4 * step;
    if (!fresh && step < local.length * segment_local_fraction)
      local.end = t;  // too loose here: a shorter segment from t
    else
      break;
  }
  return std::max(safe, std::min(step, ahead));
}

// The far end of a region where the steps from t would not reach it: where
// f there (f_b) lies on the start side, no root lies within |f_b| over the
// rate `back` at which f may approach 0 backwards from it, so the march need
// only pass the returned reach (b when unknown; a ray passing a surface by
// is settled from both ends of the region; the organic model: 10.7 -> 9.0
// values per hit, 1.03 -> 0.86 per miss, 1.06x).
template <typename Function>
inline float segment_reach(const Function& function, int region, float t,
    float f, float b, float rate, float back, segment_state& state,
    float& f_b) {
  f_b = flt_nan;
  if (!(f == f && rate > 0 && std::abs(f) / rate < b - t)) return b;
  f_b = function.value(region, b);
  state.evaluations++;
  if (!(f_b == f_b && segment_inside(f_b) == state.start_inside)) return b;
  return back > 0 ? b - std::abs(f_b) / back : -flt_inf;
}

// March [a, b] inside one region where df/dt lies in `derivative` (finite):
// f approaches the surface at most at `rate` (segment_approach), so steps of
// |f| / rate (or of the local bound ahead) cannot pass a root; shorter ones
// are taken as the hit threshold and their ends checked. Where f moves
// strictly towards the surface over the whole region, one decisive step
// (segment_decisive_step) settles it. Returns when a change of side is
// bracketed, the stretch is done, or the budget or the cutoff ends the ray.
template <typename Function>
inline void segment_lipschitz(const Function& function, int region,
    interval derivative, bool local_bounds, float a, float b,
    const march_params& params, float hit_min, segment_state& state) {
  auto rate = segment_approach(derivative, state.start_inside);
  auto t    = a;
  auto f    = 0.0f;
  if (state.margin > 0 && state.margin_t == a &&
      state.margin >= rate * (b - a)) {
    // What the last region left of |f| crosses this one whole.
    return segment_skip(state, b, state.margin - rate * (b - a));
  }
  auto t_prev = flt_nan, f_prev = flt_nan;  // the last value before t
  if (state.have_last && state.last_t == a) {
    f      = state.last_f;
    t_prev = state.before_t;
    f_prev = state.before_f;
  } else {
    if (segment_sample(function, region, t, state)) return;
    f = state.last_f;
  }
  auto monotone = segment_monotone(derivative, state.start_inside);
  auto local    = segment_local{};
  auto back     = segment_approach(derivative, !state.start_inside);
  auto f_b      = flt_nan;
  auto reach    = monotone ? b
                           : segment_reach(function, region, t, f, b, rate, back,
                                 state, f_b);
  if (reach < b && t + std::abs(f) / rate > reach)
    return segment_advance(state, b, f_b);
  while (t < b) {
    if (t > state.cutoff || state.evaluations >= state.max_evaluations) return;
    // |f| / rate (any step where f cannot approach 0); a NaN value (no
    // finite slope should allow one) steps by the threshold.
    auto safe     = f != f ? 0.0f : rate > 0 ? std::abs(f) / rate : flt_inf;
    auto epsilon  = segment_epsilon(params, hit_min, t);
    auto decisive = monotone && f == f && t + safe < b;
    if (decisive) {
      safe = segment_decisive_step(
          derivative, state.start_inside, f, b - t, epsilon);
    } else if (local_bounds) {
      safe = segment_local_step(
          function, region, t, b, f, safe, epsilon, local, state, decisive);
    }
    if (!decisive && t + safe > reach && reach < b)
      return segment_advance(state, b, f_b);
    if (!decisive && t + safe >= b) {
      // No root before the end: the next region takes over from there,
      // with what the region's bound leaves of |f| at b.
      auto margin = std::abs(f) - rate * (b - t);
      segment_skip(state, b, margin > 0 ? margin : 0);
      return;
    }
    auto step  = decisive ? safe : std::max(safe, epsilon);
    auto bold  = decisive ? 0.0f
                          : segment_bold_step(f, t - t_prev, f_prev - f, rate,
                                back, state.start_inside);
    auto batch = bold > step && t + bold < reach
                     ? segment_bold_batch(function, region, t, f, t_prev,
                           f_prev, rate, back, reach, epsilon, state)
                     : -1;
    if (state.found) return;
    if (batch > 0) continue;
    if (batch < 0 && bold > step && t + bold < reach) {
      // Verified from both ends: no root lies within |f| / rate after t
      // nor within |f_n| / back before t + bold; where these cover the
      // step, it crossed none.
      auto f_n = function.value(region, t + bold);
      state.evaluations++;
      if (f_n == f_n && segment_inside(f_n) == state.start_inside &&
          safe + std::abs(f_n) / back > bold) {
        t_prev = t, f_prev = f;
        t = t + bold, f = f_n;
        segment_advance(state, t, f);
        continue;
      }
    }
    if (!decisive && batch <= 0 &&
        segment_plain_batch(function, region, t, f, t_prev, f_prev, step,
            epsilon, b, state) > 0) {
      if (state.found) return;
      continue;
    }
    auto next = std::min(t + step, b);
    if (next <= t) next = float_up(t, 1);
    if (segment_sample(function, region, next, state)) return;
    t_prev = t, f_prev = f;
    t = next;
    f = state.last_f;
  }
}

// One piece of a region's stretch of the ray, for root isolation; a gap
// (no longer than the hit threshold, around a jump) is only sampled at its
// end.
struct segment_piece {
  float a = 0, b = 0;
  bool  gap = false;
};

// Whether f is NaN at both ends of a piece (the start's value is known
// when the march checked it last): such a piece of a region where the value
// may be NaN is taken as lying in a NaN region and not bisected further.
template <typename Function>
inline bool segment_nan_ends(const Function& function, int region,
    const segment_piece& piece, segment_state& state) {
  auto known = state.have_last && state.last_t == piece.a;
  auto fa    = known ? state.last_f : function.value(region, piece.a);
  if (!known) state.evaluations++;
  if (fa == fa) return false;
  auto fb = function.value(region, piece.b);
  state.evaluations++;
  return fb != fb;
}

// Isolate the first root in [a, b] inside one region without a finite
// slope bound: bisect, nearest half first, dropping pieces whose range
// excludes 0, marching those with a finite slope bound, and sampling the end
// of pieces shorter than the hit threshold (or, where the value may be NaN
// and is NaN at both ends, shorter than `coarse`).
template <typename Function>
inline void segment_isolate(const Function& function, int region,
    interval region_range, float a, float b, float coarse,
    const march_params& params, float hit_min, segment_state& state) {
  // A short stretch of a region that may be NaN (the octree splits those
  // down to its deepest cells: their range never decides them) costs its
  // end samples only when it is NaN at both.
  if (is_entire(region_range) && b - a <= coarse &&
      segment_nan_ends(function, region, {a, b}, state)) {
    state.last_t    = b;
    state.have_last = false;
    return;
  }
  segment_piece stack[segment_stack_size];
  auto          count = 0;
  stack[count++]      = {a, b};
  while (count > 0 && !state.found) {
    auto piece = stack[--count];
    if (piece.a > state.cutoff || state.evaluations >= state.max_evaluations)
      return;
    if (piece.gap) {
      if (segment_sample(function, region, piece.b, state)) return;
      continue;
    }
    // Where f may jump inside (a repeat's border, floor, mod), a gap of the hit
    // threshold around it is sampled at its end, and the parts on either
    // side are taken in turn: a piece across a border has no slope bound
    // and a range as wide as a whole copy's, so bounding it would be a
    // wasted evaluation, and halving it would close in on the jump only
    // after as many levels as the piece has thresholds in it.
    auto gap    = segment_epsilon(params, hit_min, piece.a) * 0.5f;
    auto border = piece.b - piece.a > 2 * gap
                      ? function.split(region, piece.a, piece.b)
                      : flt_nan;
    if (border - gap > piece.a && border + gap < piece.b &&
        count + 3 <= segment_stack_size) {
      stack[count++] = {border + gap, piece.b};
      stack[count++] = {border - gap, border + gap, true};
      stack[count++] = {piece.a, border - gap};
      continue;
    }
    auto bound = function.bound(region, piece.a, piece.b);
    state.evaluations++;
    auto range = bound.range;
    if (segment_one_side(range)) {
      // One side over the whole piece: a change of side at its start if it
      // is the other one (a jump), else nothing in it.
      if ((range.hi < 0) != state.start_inside)
        return segment_bracket(state, piece.a);
      state.last_t    = piece.b;
      state.have_last = false;
      continue;
    }
    if (segment_slope(bound.derivative) < flt_inf) {
      // A piece between jumps may be long: bounds ahead pay there (the
      // repetition written with mod: 9.1 evaluations per ray, 17 without).
      segment_lipschitz(function, region, bound.derivative, true, piece.a,
          piece.b, params, hit_min, state);
      continue;
    }
    auto length = piece.b - piece.a;
    auto small  = length <= segment_epsilon(params, hit_min, piece.a) ||
                 (is_entire(range) && length <= coarse &&
                     segment_nan_ends(function, region, piece, state));
    auto mid = piece.a + length * 0.5f;
    if (small || count + 2 > segment_stack_size || !(mid > piece.a) ||
        !(mid < piece.b)) {
      if (segment_sample(function, region, piece.b, state)) return;
      continue;
    }
    stack[count++] = {mid, piece.b};
    stack[count++] = {piece.a, mid};
  }
}

// Refine a bracket [lo, hi] (lo on the start side, hi on the other) to the
// root: a secant step first where f is known at both ends, then Newton
// steps on the exact derivative from the last point evaluated, bisection
// when a step leaves the bracket. Newton's iterates near a root approach it
// from one side and would leave the far end of the bracket where it is, so
// a correction shorter than half the tolerance steps half the tolerance
// instead: past the root, which closes the bracket. Returns the start-side
// end.
template <typename Function>
inline float segment_refine(const Function& function, float lo, float hi,
    float f_lo, float f_hi, bool start_inside, float tolerance,
    int& evaluations) {
  auto x = 0.0f, fx = 0.0f, gx = 0.0f;
  auto have_point = false;
  for (auto step = 0; step < segment_root_steps; step++) {
    auto width = std::max(tolerance, 4 * flt_eps * std::abs(hi));
    if (!(hi - lo > width)) break;
    auto next  = lo + (hi - lo) * 0.5f;
    auto guess = next;
    if (have_point && gx != 0) {
      auto delta = -fx / gx;
      if (std::abs(delta) < width * 0.5f)
        delta = std::copysign(width * 0.5f, delta);
      guess = x + delta;
    } else if (step == 0 && std::isfinite(f_lo - f_hi) && f_lo != f_hi) {
      guess = lo + (hi - lo) * (f_lo / (f_lo - f_hi));
    }
    if (guess > lo && guess < hi) next = guess;
    auto region = function.locate(next).region;
    auto value  = function.value_slope(region, next);
    evaluations++;
    x          = next;
    fx         = value.x;
    gx         = value.y;
    have_point = std::isfinite(fx) && std::isfinite(gx);
    if (segment_inside(fx) == start_inside) {
      lo = x;
    } else {
      hi = x;
    }
  }
  return lo;
}

// First change of side of the function along the ray in [t0, t1]; gives up
// (no hit) once everything it could still report lies beyond `cutoff`, or
// when its budget of evaluations is spent.
template <typename Function>
inline march_result segment_trace(const Function& function, float t0, float t1,
    float cutoff, const march_params& params, float hit_min) {
  auto result           = march_result{};
  auto state            = segment_state{};
  state.cutoff          = cutoff;
  state.max_evaluations = params.max_iterations * segment_evaluation_factor;
  auto t                = t0;
  auto region           = function.locate(t);
  if (segment_one_side(region.range)) {
    // The start's side is the region's: no evaluation (a ray that starts
    // far from the surface, as most do, costs none before its first
    // region that may hold a root).
    state.start_inside = region.range.hi < 0;
    segment_skip(state, t, 0);
  } else {
    auto f             = function.value(region.region, t);
    state.evaluations  = 1;
    state.start_inside = segment_inside(f);
    segment_advance(state, t, f);
  }
  while (t < t1 && !state.found) {
    if (state.last_t > cutoff || state.evaluations >= state.max_evaluations)
      break;
    auto end   = std::min(std::max(region.t_exit, float_up(t, 1)), t1);
    auto range = region.range;
    if (segment_one_side(range)) {
      if ((range.hi < 0) != state.start_inside) {
        segment_bracket(state, t);
      } else {
        // The range holds at the region's closed box, its exit included.
        segment_skip(state, end, range.hi < 0 ? -range.hi : range.lo);
      }
    } else if (segment_slope(region.derivative) < flt_inf) {
      segment_lipschitz(function, region.region, region.derivative,
          region.local_bounds, t, end, params, hit_min, state);
    } else {
      segment_isolate(function, region.region, range, t, end,
          (t1 - t0) * segment_nan_fraction, params, hit_min, state);
    }
    t = end;
    if (!state.found && t < t1) region = function.locate(t);
  }
  result.evaluations = state.evaluations;
  if (!state.found) return result;
  auto epsilon  = segment_epsilon(params, hit_min, state.lo);
  auto distance = segment_refine(function, state.lo, state.hi, state.f_lo,
      state.f_hi, state.start_inside, epsilon * segment_root_fraction,
      result.evaluations);
  // The march's guarantees end at the cutoff: a later hit is no hit.
  if (distance > cutoff) return result;
  result.hit      = true;
  result.distance = distance;
  result.epsilon  = epsilon;
  return result;
}

}  // namespace implicit
