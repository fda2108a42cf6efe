// # implicit: lights
//
// Emissive objects whose shape can be sampled directly (boxes and spheres
// placed by rigid frames, including the seed's flat box lights) and
// environments (constant, or lat-long textures importance sampled by texel
// luminance times sin(theta)). Other emitters are not in this list: BSDF
// rays still find them, and the mixture pdf below stays correct because it
// only describes what sample_lights() can produce.
#pragma once

#include <vector>

#include "accel.h"

namespace implicit {

enum class light_shape { box, sphere, environment };

// One light. Boxes keep a cdf over their six faces (areas); environments a
// cdf over texels.
struct trace_light {
  light_shape        shape       = light_shape::box;
  int                object      = invalidid;  // in accel_data::objects
  int                environment = invalidid;  // in scene_data::environments
  float              area        = 0;
  std::vector<float> cdf         = {};
  int                width = 0, height = 0;  // environment texture size
};

struct lights_data {
  std::vector<trace_light> lights = {};
};

// Collect the lights of a scene.
lights_data make_lights(const scene_data& scene, const accel_data& accel);

// Sample a direction toward the lights from `position` (one light picked
// uniformly by `rl`, a face or texel by `rel`, a point by `ruv`).
vec3f sample_lights(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, vec3f position, float rl, float rel, vec2f ruv);

// Solid-angle pdf of sample_lights() producing `direction` from `position`:
// every point of every light along the direction contributes.
float sample_lights_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, vec3f position, vec3f direction);

}  // namespace implicit
