// # implicit: SDF grids (placeholder until the grid tracer lands)

#include "sdf_grid.h"

namespace implicit {

bbox3f grid_bounds(const grid_data& grid) {
  auto extent = vec3f{(float)grid.dims.x - 1, (float)grid.dims.y - 1,
                    (float)grid.dims.z - 1} *
                grid.spacing;
  return {{0, 0, 0}, extent};
}

float eval_grid(const grid_data&, vec3f) { return flt_max; }

vec3f eval_grid_gradient(const grid_data&, vec3f) { return {0, 1, 0}; }

bool intersect_grid(const grid_data&, const ray3f&, float&, int& steps) {
  steps = 0;
  return false;
}

}  // namespace implicit
