// # implicit: tracing functions that are no distance bounds (internal)
//
// A function object whose program is no distance bound (math clauses of an
// expression, twist, bend, repeat: sdf_field::distance is false) has no
// step a sphere tracer could trust. It is traced by segment_trace.h over its
// field instead: the regions of the ray are the leaf cells of the field's
// octree that the ray crosses, each with the range of the values over it
// and the Lipschitz bound of its simplified tape (sdf_cell), and a piece of
// a region is bounded by its own tape's interval derivatives over the
// piece's box, projected on the ray (a bound of df/dt, tighter than the
// gradient's length). Without an octree (small programs, and the reference
// mode `none`) the whole box is one region with the whole tape and its
// bound over the whole box (trace_object::whole_range, whole_lipschitz).
// Normals are the exact gradient of the leaf's tape (forward-mode dual
// numbers), not finite differences.
#pragma once

#include "accel.h"
#include "sphere_trace.h"

namespace implicit {

// Set the whole tape's range and Lipschitz bound over the object's padded
// local box (make_accel, once per object).
void init_field_bounds(trace_object& object);

// First change of side of the object's function along `local` (the ray in
// the object's space, t in world units) in [t0, t1]; see segment_trace().
march_result trace_field(const trace_object& object, const march_params& params,
    const ray3f& local, float t0, float t1, float cutoff, float hit_min);

// Unit gradient of the field at a local point: the exact gradient of its
// leaf's tape; finite differences of step `step` where that vanishes or is
// not finite (a critical point, a kink).
vec3f eval_field_gradient(const sdf_field& field, vec3f p, float step);

}  // namespace implicit
