// # implicit: random scenes
//
// Workloads of the tests and benchmarks: clouds of random primitives (many
// bounded objects with uneven scales, so that their distance bounds are not
// exact) at any count, and scenes around one large model.
#pragma once

#include <cstdint>

#include "scene.h"

namespace implicit {

// Adds `count` objects to the scene: boxes, spheres, tori and capped cones
// in turn, each rotated uniformly at random, scaled by `size` times 0.6-1.4
// independently per axis, and centred uniformly at random in the cube
// [-extent, extent]^3 less a margin of size / 2. Materials are drawn
// uniformly from [0, materials); the same seed gives the same objects.
void add_random_primitives(scene_data& scene, int count, float extent,
    float size, int materials, uint64_t seed);

// One sdfunction named "model" holding `program` (such as the models of
// sdf/sdf_models.h, which fill [-1,1]^3) with `material`, a white sky and a
// camera looking at that cube.
scene_data make_model_scene(sdf_program program, const material_data& material);

}  // namespace implicit
