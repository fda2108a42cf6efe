// # implicit: lights
//
// Emissive objects whose shape can be sampled directly (boxes and spheres
// placed by rigid frames, including the seed's flat box lights) and
// environments (constant, or lat-long textures importance sampled by texel
// luminance times sin(theta), summed over cells of at most 2^17 per image,
// as coarse as the image allows, through an alias table). One light is chosen
// uniformly per sample: picking by power (pbrt's flux, the sky's through a
// disk of the scene's radius) made the seed's 07_sdfunction 10-15% noisier
// at equal samples, since its lamp matters more near the objects than its
// flux says. Other emitters
// are not in this list: BSDF rays still find them, and the mixture pdf below
// stays correct because it only describes what sample_lights() can produce.
#pragma once

#include <vector>

#include "../math/alias.h"
#include "accel.h"

namespace implicit {

enum class light_shape { box, sphere, environment };

// One light. Boxes keep a cdf over their six faces (areas); textured
// environments an alias table over cells of texels and the cells' weights.
// Cells keep the tables small enough to stay in cache (at most 512x256 cells,
// 1.5 MB, against 16 MB for a table over 2048x1024 texels; the seed's smooth
// sky needs only 64x32, 24 KB); directions are uniform in uv within a cell,
// so the pdf is the cell's probability over its solid angle, whatever the
// weights.
struct trace_light {
  light_shape        shape       = light_shape::box;
  int                object      = invalidid;  // in accel_data::objects
  int                environment = invalidid;  // in scene_data::environments
  float              area        = 0;
  std::vector<float> cdf         = {};
  alias_table        cells       = {};
  // Solid-angle pdf of each cell (row-major) times sin(theta): its
  // probability over the cell's uv area and 2 pi^2 (one float per cell, so
  // the lookup on every bounce stays in cache and needs no division).
  std::vector<float> cell_pdfs = {};
  int                width = 0, height = 0;  // environment cells
  // World bounding sphere of a box or sphere light: most directions miss
  // the light, and this test rejects them before the exact one.
  vec3f center = {0, 0, 0};
  float radius = 0;
};

struct lights_data {
  std::vector<trace_light> lights = {};
  // Inverse frame of every scene environment (lights or not), so that
  // escaped rays need no 3x3 inverse.
  std::vector<frame3f> env_from_world = {};
};

// Collect the lights of a scene.
lights_data make_lights(const scene_data& scene, const accel_data& accel);

// Radiance of the scene's environments along a world direction, as
// eval_environment(scene, direction) with the inverse frames kept in
// `lights` by make_lights() (without them, it inverts them per call).
vec3f eval_environment(
    const scene_data& scene, const lights_data& lights, vec3f direction);

// Sample a direction toward the lights from `position` (one light picked
// uniformly by `rl`, a face or cell by `rel`, a point by `ruv`). For a
// textured environment it also starts reading the texels the direction's
// radiance needs once its ray is traced (large skies miss the cache).
vec3f sample_lights(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, vec3f position, float rl, float rel, vec2f ruv);

// Solid-angle pdf of sample_lights() producing `direction` from `position`:
// every point of every light along the direction contributes. Like
// sample_lights(), it starts reading the sky's texels along the direction:
// the pdf of a direction is wanted just before its ray is traced.
float sample_lights_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, vec3f position, vec3f direction);

}  // namespace implicit
