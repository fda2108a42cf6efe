// # implicit: Embree BVH over implicit objects (internal to accel.cpp)
//
// Every bounded object is one Embree user primitive whose box is its world
// bounds, padded. The intersect callback runs intersect_object() for that
// primitive and keeps the closest hit (equal distances: the lower object
// index), the occluded callback stops at the first hit.
#pragma once

#include "accel.h"

namespace implicit {

// Build the BVH of accel.bounded. Throws io_error if Embree fails.
embree_bvh make_embree_bvh(const accel_data& accel);

// Closest hit among the bounded objects; `evaluations` counts all of them.
scene_intersection intersect_embree(
    const accel_data& accel, const march_params& march, const ray3f& ray);

// Whether any bounded object is hit.
bool intersect_embree_any(
    const accel_data& accel, const march_params& march, const ray3f& ray);

}  // namespace implicit
