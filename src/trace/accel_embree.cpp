// # implicit: Embree BVH over implicit objects (implementation)
//
// Embree 3 user geometry: one geometry holding one user primitive per bounded
// object (primitive index = index in accel.bounded). Single rays go through
// rtcIntersect1/rtcOccluded1; the callbacks find the accel and the original
// ray in an extended intersect context (Embree's documented way of passing
// per-ray data), so nothing is allocated per ray and the accel may move.

#include <embree3/rtcore.h>

#include <cassert>
#include <cmath>
#include <string>
#include <utility>

#include "../util/error.h"
#include "accel_embree.h"

namespace implicit {

// -----------------------------------------------------------------------------
// OWNER
// -----------------------------------------------------------------------------

embree_bvh::embree_bvh(embree_bvh&& other) noexcept
    : device{std::exchange(other.device, nullptr)},
      scene{std::exchange(other.scene, nullptr)} {}

embree_bvh& embree_bvh::operator=(embree_bvh&& other) noexcept {
  if (this != &other) {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
    device = std::exchange(other.device, nullptr);
    scene  = std::exchange(other.scene, nullptr);
  }
  return *this;
}

embree_bvh::~embree_bvh() {
  if (scene) rtcReleaseScene(scene);
  if (device) rtcReleaseDevice(device);
}

// -----------------------------------------------------------------------------
// BUILD
// -----------------------------------------------------------------------------

// Boxes of the primitives, read by the bounds callback during the build only.
struct embree_build_data {
  std::vector<RTCBounds> boxes = {};
};

// Embree bounds callback: the padded world box of one object.
static void embree_bounds(const RTCBoundsFunctionArguments* args) {
  auto& data      = *(const embree_build_data*)args->geometryUserPtr;
  *args->bounds_o = data.boxes[args->primID];
}

// Throw if the device reports an error (setup code only).
static void check_embree(RTCDevice device, const char* place) {
  auto error = rtcGetDeviceError(device);
  if (error != RTC_ERROR_NONE)
    throw io_error(std::string{"embree: "} + place + ": error " +
                   std::to_string((int)error));
}

static void embree_intersect(const RTCIntersectFunctionNArguments* args);
static void embree_occluded(const RTCOccludedFunctionNArguments* args);

embree_bvh make_embree_bvh(const accel_data& accel) {
  auto bvh = embree_bvh{};
  if (accel.bounded.empty()) return bvh;
  bvh.device = rtcNewDevice(nullptr);
  if (!bvh.device)
    throw io_error("embree: rtcNewDevice: cannot create a device");
  // Embree's box tests are in float: widen each box a little more than the
  // interval that intersect_object() clips to, relative to its coordinates.
  auto data = embree_build_data{};
  auto pad  = accel.padding;
  for (auto index : accel.bounded) {
    auto& box   = accel.objects[index].world_bounds;
    auto  scale = std::max(max(abs(box.min)), max(abs(box.max)));
    auto  wide  = expand(box, 2 * pad + scale * 4 * flt_eps);
    data.boxes.push_back({wide.min.x, wide.min.y, wide.min.z, 0, wide.max.x,
        wide.max.y, wide.max.z, 0});
  }
  bvh.scene = rtcNewScene(bvh.device);
  rtcSetSceneFlags(bvh.scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(bvh.scene, RTC_BUILD_QUALITY_HIGH);
  auto geometry = rtcNewGeometry(bvh.device, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(geometry, (unsigned)accel.bounded.size());
  rtcSetGeometryUserData(geometry, &data);
  rtcSetGeometryBoundsFunction(geometry, embree_bounds, nullptr);
  rtcSetGeometryIntersectFunction(geometry, embree_intersect);
  rtcSetGeometryOccludedFunction(geometry, embree_occluded);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(bvh.scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(bvh.scene);
  check_embree(bvh.device, "building the BVH");
  return bvh;
}

// -----------------------------------------------------------------------------
// TRAVERSAL
// -----------------------------------------------------------------------------

// Embree's context followed by what the callbacks need (Embree passes the
// pointer given to rtcIntersect1 back to the callbacks).
struct embree_context {
  RTCIntersectContext context     = {};  // must come first
  const accel_data*   accel       = nullptr;
  const march_params* march       = nullptr;
  const ray3f*        ray         = nullptr;  // with the caller's tmax
  int                 object      = invalidid;
  float               epsilon     = 0;
  int                 evaluations = 0;
};

// Intersect callback: march the object over its whole box interval, giving
// up past the current closest hit; keep the closer hit, or on a tie the lower
// object index, so the result does not depend on the traversal order.
static void embree_intersect(const RTCIntersectFunctionNArguments* args) {
  assert(args->N == 1);
  if (!args->valid[0]) return;
  auto& context = *(embree_context*)args->context;
  auto& rayhit  = *(RTCRayHit*)args->rayhit;
  auto  object  = context.accel->bounded[args->primID];
  auto  tfar    = rayhit.ray.tfar;
  auto  isec    = intersect_object(
          *context.accel, *context.march, object, *context.ray, tfar);
  context.evaluations += isec.evaluations;
  if (!isec.hit || isec.distance > tfar) return;
  if (isec.distance == tfar && context.object != invalidid &&
      context.object < object)
    return;
  rayhit.ray.tfar   = isec.distance;
  rayhit.hit.geomID = args->geomID;
  rayhit.hit.primID = args->primID;
  rayhit.hit.u      = 0;
  rayhit.hit.v      = 0;
  rayhit.hit.Ng_x   = 0;
  rayhit.hit.Ng_y   = 0;
  rayhit.hit.Ng_z   = 0;
  context.object    = object;
  context.epsilon   = isec.epsilon;
}

// Occluded callback: any hit of the object ends the query (tfar = -inf is
// Embree's convention for "occluded").
static void embree_occluded(const RTCOccludedFunctionNArguments* args) {
  assert(args->N == 1);
  if (!args->valid[0]) return;
  auto& context = *(embree_context*)args->context;
  auto& ray     = *(RTCRay*)args->ray;
  auto  object  = context.accel->bounded[args->primID];
  auto  isec    = intersect_object(
          *context.accel, *context.march, object, *context.ray, context.ray->tmax);
  context.evaluations += isec.evaluations;
  if (isec.hit) ray.tfar = -flt_inf;
}

// Embree's ray for one of ours.
static RTCRay make_embree_ray(const ray3f& ray) {
  auto result  = RTCRay{};
  result.org_x = ray.o.x;
  result.org_y = ray.o.y;
  result.org_z = ray.o.z;
  result.dir_x = ray.d.x;
  result.dir_y = ray.d.y;
  result.dir_z = ray.d.z;
  result.tnear = ray.tmin;
  result.tfar  = ray.tmax;
  result.mask  = 0xffffffffu;
  result.flags = 0;
  result.time  = 0;
  return result;
}

scene_intersection intersect_embree(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  auto isec = scene_intersection{};
  if (!accel.bvh.scene) return isec;
  auto context  = embree_context{};
  context.accel = &accel;
  context.march = &march;
  context.ray   = &ray;
  rtcInitIntersectContext(&context.context);
  auto rayhit       = RTCRayHit{};
  rayhit.ray        = make_embree_ray(ray);
  rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rayhit.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(accel.bvh.scene, &context.context, &rayhit);
  isec.evaluations = context.evaluations;
  if (context.object != invalidid) {
    isec.hit      = true;
    isec.object   = context.object;
    isec.distance = rayhit.ray.tfar;
    isec.epsilon  = context.epsilon;
  }
  return isec;
}

bool intersect_embree_any(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  if (!accel.bvh.scene) return false;
  auto context  = embree_context{};
  context.accel = &accel;
  context.march = &march;
  context.ray   = &ray;
  rtcInitIntersectContext(&context.context);
  auto embree_ray = make_embree_ray(ray);
  rtcOccluded1(accel.bvh.scene, &context.context, &embree_ray);
  return embree_ray.tfar == -flt_inf;
}

}  // namespace implicit
