// # implicit: where a block of camera rays may first meet a surface
//
// A first pass over blocks of pixels: for the rays of a block (a pinhole
// camera's cone through the block's corners), a conservative distance before
// which none of them can meet a surface, from the boxes that may hold one:
// the leaves of an object's octree whose range does not exclude a hit
// (sdf_field.h), or the padded box of an object without one, the objects
// taken from accel_data::block_tree nearest first. The rays of the
// block then start there instead of at the camera, and a block that meets
// no such box is a miss for all its rays. A perfect first pass (each
// pixel's own depth) made the organic model of bench/make_organic.py 1.6x
// faster; blocks of 8 x 8 pixels starting at their nearest hit, 1.28x;
// this pass, 1.16x.
//
// The pass depends on the block alone (not on which tile or thread renders
// it), so images stay the same at any thread and rank count. The hits it
// leads to are those of a march from the camera (no surface lies before the
// start); their last bits may differ, as the march takes other steps.
#pragma once

#include "../scene/scene.h"
#include "accel.h"

namespace implicit {

// Pixels per side of a block (blocks are aligned to the image's corner).
inline constexpr int camera_block_size = 8;

// Distance along the camera rays of pixels [lo.x, hi.x) x [lo.y, hi.y) of an
// image of `size` pixels before which none meets a surface: 0 when unknown (a
// lens, an orthographic camera, the reference mode `none`), flt_max when no
// ray of the block meets anything. `tent`: samples reach half a pixel
// beyond their pixel (the tent filter). Builds the octree cells it visits.
float camera_block_start(const accel_data& accel, const march_params& march,
    const camera_data& camera, vec2i size, vec2i lo, vec2i hi, bool tent);

}  // namespace implicit
