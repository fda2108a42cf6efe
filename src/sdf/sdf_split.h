// # implicit: union parts of SDF programs
//
// A hard union at the root of a program is the minimum of its operands, so
// each bounded operand can be traced on its own, inside its own box (the
// accelerator makes them separate BVH primitives).
#pragma once

#include <vector>

#include "sdf_program.h"

namespace implicit {

// The operands of the hard union at the root of `program`, through
// transforms and nested hard unions, each as its own program in the
// program's space (the transforms above it merged into one). Operands with
// unbounded or empty boxes stay together as one more part, the union of
// them. A program whose root is no hard union is its own only part.
std::vector<sdf_program> split_sdf_union(const sdf_program& program);

}  // namespace implicit
