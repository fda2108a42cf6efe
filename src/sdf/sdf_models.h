// # implicit: large procedural SDF models
//
// The workloads of the large-model tests and benchmarks (issue 11): one
// program of many operands, as SDF modelling produces them, built the way
// the JSON loader combines `operands` lists (fold_sdf_operands). All fill the
// cube
// [-1,1]^3 (the slab: its middle) at any count, so that costs compare across
// counts.
#pragma once

#include <cstdint>

#include "sdf_program.h"

namespace implicit {

enum class sdf_model_type { hard_union, smooth_union, perforated_slab };
inline const std::vector<std::string> sdf_model_type_names = {
    "hard_union", "smooth_union", "perforated_slab"};

// A model of `count` operands:
// - hard_union: spheres and boxes alternately at jittered grid points, about
//   a third of the spacing in size;
// - smooth_union: spheres (radius 0.3 x the spacing) blended with 0.6 x the
//   spacing, a blob;
// - perforated_slab: a slab 0.2 thick minus `count` cylinders through it
//   (radius 0.3 x the spacing of their square grid).
// The same seed gives the same model.
sdf_program make_sdf_model(sdf_model_type type, int count, uint64_t seed);

}  // namespace implicit
