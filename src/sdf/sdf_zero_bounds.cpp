// # implicit: bounds of a zero set by interval subdivision (programs)

#include "sdf_zero_bounds.h"

#include <cmath>

#include "sdf_tape.h"

namespace implicit {

bbox3f sdf_surface_bounds(const sdf_program& program, bool& unbounded) {
  unbounded = false;
  auto box  = sdf_bounds(program);
  if (is_finite(box) || std::isfinite(sdf_lipschitz(program))) return box;
  auto tape = make_sdf_tape(program);
  // The natural interval extension, narrowed by the mean value form
  // f(centre) + gradient range * (box - centre) where that is finite: it
  // removes most of the dependency problem (x*x - x*x) on small cells.
  auto range = [&](const bbox3f& cell) {
    auto f = eval_sdf_dual(tape, cell);
    auto c = center(cell);
    auto v = eval_sdf(tape, c);
    if (!(v == v)) return f.v;
    auto r = interval{v};
    for (auto a = 0; a < 3; a++)
      r = r + f.d[a] * interval{at(cell.min, a) - at(c, a),
                           at(cell.max, a) - at(c, a)};
    if (is_entire(f.v) || is_entire(r)) return f.v;
    return interval{std::max(f.v.lo, r.lo), std::min(f.v.hi, r.hi)};
  };
  auto found = find_zero_bounds(range);
  unbounded  = found.unbounded;
  return found.bounds;
}

}  // namespace implicit
