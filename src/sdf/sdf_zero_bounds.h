// # implicit: bounds of a zero set by interval subdivision
//
// A closed-form expression without `bounds` says nothing about where its
// surface lies. Interval arithmetic does: a cell over which the value's
// range excludes 0 holds none of it. So the box of the zero set is found
// as interval methods find roots (Moore 1966; Snyder 1992, "Interval
// Analysis for Computer Graphics"): split a large cube into eight, keep the
// cells whose range may hold 0 (or may be NaN: a NaN region may border the
// inside), split those again, level by level; the kept cells of the last
// level cover the zero set. A second round over their box, and more, shrink
// it until it stops shrinking. A zero set that still reaches the faces of
// the first cube is unbounded as far as the renderer can tell (a gyroid, an
// extrusion, a half-space of NaN): the caller refuses it and asks for
// `bounds`.
#pragma once

#include <vector>

#include "../math/interval.h"
#include "sdf_program.h"

namespace implicit {

// How far the search goes.
struct zero_bounds_params {
  float search_size = 8192;  // half size of the first cube, local units
  int   levels      = 8;     // levels of subdivision per round
  int   max_cells   = 2048;  // a round stops at the level that keeps more
  int   max_rounds  = 8;     // rounds until the box stops shrinking
  float shrink      = 0.9f;  // a round that keeps more of the box stops
};

struct zero_bounds_result {
  bbox3f bounds    = {};     // holds the zero set (empty: none found)
  bool   unbounded = false;  // the zero set reaches the first cube's faces
};

// One round over `box`: the box of the kept cells of the deepest level
// within the budget, and whether a kept cell touches the faces of `box`.
// `range(cell)` encloses the values over a cell (entire where they may be
// NaN).
template <typename Range>
inline zero_bounds_result zero_bounds_round(
    const Range& range, const bbox3f& box, const zero_bounds_params& params) {
  auto cells  = std::vector<bbox3f>{};
  auto next   = std::vector<bbox3f>{};
  auto values = range(box);
  if (values.lo <= 0 && values.hi >= 0) cells.push_back(box);
  for (auto level = 0; level < params.levels && !cells.empty(); level++) {
    next.clear();
    for (auto& cell : cells) {
      auto mid = center(cell);
      for (auto octant = 0; octant < 8; octant++) {
        auto child = cell;
        for (auto a = 0; a < 3; a++) {
          auto& side = (octant >> a) & 1 ? at(child.min, a) : at(child.max, a);
          side       = at(mid, a);
        }
        auto child_values = range(child);
        if (child_values.lo <= 0 && child_values.hi >= 0) next.push_back(child);
      }
      if ((int)next.size() > params.max_cells) break;
    }
    if ((int)next.size() > params.max_cells) break;
    std::swap(cells, next);
  }
  auto result = zero_bounds_result{};
  for (auto& cell : cells) {
    result.bounds = merge(result.bounds, cell);
    for (auto a = 0; a < 3; a++)
      if (at(cell.min, a) <= at(box.min, a) ||
          at(cell.max, a) >= at(box.max, a))
        result.unbounded = true;
  }
  return result;
}

// The box of the zero set of the function whose ranges over boxes `range`
// gives, or `unbounded` if it reaches the faces of the cube of half size
// params.search_size about the origin.
template <typename Range>
inline zero_bounds_result find_zero_bounds(
    const Range& range, const zero_bounds_params& params = {}) {
  auto s     = params.search_size;
  auto first = bbox3f{{-s, -s, -s}, {s, s, s}};
  auto found = zero_bounds_round(range, first, params);
  if (found.unbounded || is_empty(found.bounds)) return found;
  for (auto round = 1; round < params.max_rounds; round++) {
    auto again = zero_bounds_round(range, found.bounds, params);
    if (is_empty(again.bounds)) break;  // a budget cut before any level
    auto kept    = size(again.bounds) / size(found.bounds);
    found.bounds = again.bounds;
    if (max(kept) > params.shrink) break;
  }
  return found;
}

// Box of a program's surface, in its local space: sdf_bounds() where that is
// finite or the program is a distance bound (a plane is traced unbounded);
// otherwise (math clauses or warps whose box sdf_bounds cannot tell) the
// box of the zero set found by find_zero_bounds() over the program's tape,
// with ranges narrowed by the mean value form. `unbounded` tells that the
// search reached its cube's faces: the caller refuses the program.
bbox3f sdf_surface_bounds(const sdf_program& program, bool& unbounded);

// What loaders and make_accel say of a program that sdf_surface_bounds()
// finds unbounded.
inline constexpr const char* unbounded_surface_message =
    "the surface is unbounded (interval subdivision finds it on the faces of "
    "a cube of half size 8192, or finds NaN there): give the expression "
    "`bounds` [[x0, y0, z0], [x1, y1, z1]] to clip it to a box";

}  // namespace implicit
