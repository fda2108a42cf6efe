// # implicit: rendering (implementation)

#include "trace.h"

#include <array>

#include "../math/sampling.h"
#include "../math/sobol.h"
#include "shading.h"

namespace implicit {

// -----------------------------------------------------------------------------
// SURFACE POINTS
// -----------------------------------------------------------------------------

// What the shaders need at a hit.
struct surface_point {
  vec3f          position = {0, 0, 0};
  vec3f          normal   = {0, 0, 1};
  float          epsilon  = 0;  // hit threshold, for spawning rays
  material_point material = {};
};

// Texture lookup by triplanar mapping in the object's space (implicit
// surfaces have no uv): three planar projections blended by the normal's
// components raised to a power, so that each face takes its dominant axis.
// One texture repeat per unit of object space.
static vec4f eval_triplanar(
    const scene_data& scene, int texture, vec3f p, vec3f n) {
  if (texture < 0 || texture >= (int)scene.textures.size()) return {1, 1, 1, 1};
  auto w = abs(n);
  w      = w * w * w * w;
  w      = w / std::max(sum(w), 1e-8f);
  auto x = eval_texture(scene, texture, {p.z, -p.y});
  auto y = eval_texture(scene, texture, {p.x, p.z});
  auto z = eval_texture(scene, texture, {p.x, -p.y});
  return x * w.x + y * w.y + z * w.z;
}

// Material at a point, with its textures looked up in object space.
static material_point eval_material(const scene_data& scene,
    const trace_object& object, vec3f position, vec3f normal) {
  if (object.material < 0 || object.material >= (int)scene.materials.size())
    return {};
  auto& material = scene.materials[object.material];
  auto  textured = material.color_tex >= 0 || material.emission_tex >= 0 ||
                  material.roughness_tex >= 0 || material.scattering_tex >= 0;
  if (!textured) return make_material_point(material);
  // Object space before any grid scale and placement (the instance's
  // space), so textures keep their size when a grid instance is scaled.
  auto is_grid = object.kind == object_kind::grid;
  auto scale   = is_grid ? scene.vol_instances[object.index].scale : 1.0f;
  auto offset  = is_grid ? grid_placement(*object.grid) : vec3f{0, 0, 0};
  auto p =
      (transform_point(object.local_from_world, position) + offset) * scale;
  auto n = normalize(transform_vector(object.local_from_world, normal));
  return make_material_point(material,
      eval_triplanar(scene, material.color_tex, p, n),
      eval_triplanar(scene, material.emission_tex, p, n),
      eval_triplanar(scene, material.roughness_tex, p, n),
      eval_triplanar(scene, material.scattering_tex, p, n));
}

static surface_point eval_surface(const scene_data& scene,
    const accel_data& accel, const ray3f& ray, const scene_intersection& isec) {
  auto  point    = surface_point{};
  auto& object   = accel.objects[isec.object];
  point.position = ray_point(ray, isec.distance);
  point.epsilon  = isec.epsilon;
  point.normal =
      eval_object_normal(object, point.position, isec.epsilon * 0.5f);
  point.material = eval_material(scene, object, point.position, point.normal);
  return point;
}

// Start of a ray leaving a surface point toward `direction`: pushed off the
// surface on that side by more than the hit threshold, so that the march does
// not stop at its own origin (no acne).
static ray3f spawn_ray(const accel_data& accel, const march_params& march,
    const surface_point& point, vec3f direction) {
  auto offset = 2 * point.epsilon + 2 * min_hit_epsilon(accel, march);
  auto side   = dot(point.normal, direction) >= 0 ? 1.0f : -1.0f;
  return {
      point.position + point.normal * (offset * side), direction, 0, flt_max};
}

// -----------------------------------------------------------------------------
// PATH TRACING
// -----------------------------------------------------------------------------

// Power heuristic (Veach 1997) with exponent 2.
static float power_heuristic(float pdf, float other) {
  return pdf * pdf / (pdf * pdf + other * other);
}

// Most surfaces a light sample crosses before it gives up (opacity and
// volumetric boundaries).
inline constexpr int max_crossings = 16;

// A surface that stops light samples and adds nothing to them: opaque
// everywhere (no color texture whose alpha could lower it), emitting nothing,
// not a volumetric pass-through. Light samples that hit one need neither its
// normal nor its textures.
static bool blocks_without_emission(
    const scene_data& scene, const trace_object& object) {
  if (object.material < 0 || object.material >= (int)scene.materials.size())
    return false;
  auto& material = scene.materials[object.material];
  return material.type != material_type::volumetric && material.opacity >= 1 &&
         material.color_tex < 0 && max(material.emission) <= 0;
}

// Emission of one light arriving at a point along `ray` without
// scattering: for a shape light, what its object's surfaces emit where the
// ray meets them; for an environment, its radiance if the ray escapes. It is
// attenuated by what the ray crosses: surfaces with opacity let (1 -
// opacity) through and volumetric (pass-through) objects attenuate by their
// transmittance, both deterministically; any other surface blocks. Other
// emitters add nothing here: their own light samples count them. The object
// alone is traced first: a direction of its cone that misses it carries
// nothing, and no scene ray is traced for it (box lights aim only at their
// box).
static vec3f eval_light(const scene_data& scene, const accel_data& accel,
    const march_params& march, const lights_data& lights, int light, ray3f ray,
    int64_t& evaluations) {
  auto& source = lights.lights[light];
  auto  object =
      source.shape == light_shape::environment ? invalidid : source.object;
  if (object >= 0 && source.shape == light_shape::cone) {
    auto first = intersect_object(accel, march, object, ray);
    evaluations += first.evaluations;
    if (!first.hit) return {0, 0, 0};
  }
  auto transmittance = vec3f{1, 1, 1};
  auto radiance      = vec3f{0, 0, 0};
  auto inside        = std::array<int, 8>{};  // volumetric objects entered
  auto inside_count  = 0;
  auto entry         = std::array<vec3f, 8>{};
  for (auto crossing = 0; crossing < max_crossings; crossing++) {
    auto isec = intersect_scene(accel, march, ray);
    evaluations += isec.evaluations;
    if (!isec.hit) {
      if (object >= 0) return radiance;
      return transmittance *
             eval_environment_light(scene, lights, source, ray.d);
    }
    if (isec.object != object &&
        blocks_without_emission(scene, accel.objects[isec.object]))
      return radiance;
    auto  point    = eval_surface(scene, accel, ray, isec);
    auto& material = point.material;
    if (isec.object == object)
      radiance += transmittance * material.opacity *
                  eval_emission(material, point.normal, -ray.d);
    if (material.type != material_type::volumetric) {
      if (material.opacity >= 1) return radiance;
      transmittance *= 1 - material.opacity;
    } else {
      // Entering or leaving a homogeneous medium: attenuate on exit.
      auto found = -1;
      for (auto k = 0; k < inside_count; k++)
        if (inside[k] == isec.object) found = k;
      if (found < 0 && inside_count < (int)inside.size()) {
        inside[inside_count]  = isec.object;
        entry[inside_count++] = point.position;
      } else if (found >= 0) {
        transmittance *= eval_transmittance(
            material.density, distance(entry[found], point.position));
        inside[found] = inside[--inside_count];
        entry[found]  = entry[inside_count];
      }
    }
    if (max(transmittance) <= 0) return radiance;
    ray = spawn_ray(accel, march, point, ray.d);
  }
  return radiance;
}

// The homogeneous media the path is inside (closed refractive, subsurface or
// volumetric objects), innermost last. Fixed size: no allocation per path.
struct volume_stack {
  std::array<material_point, 8> items = {};
  int                           size  = 0;
};

// The random numbers of one path: the next dimensions of the pixel's
// scrambled Sobol sample, or the pixel's PCG32 stream. Callers draw them into
// named locals, one statement each, so that which dimension feeds which
// parameter does not depend on the compiler's argument evaluation order.
struct path_sampler {
  sampler_type type  = sampler_type::sobol;
  sobol_state  sobol = {};
  rng_state*   rng   = nullptr;
};

static float next1f(path_sampler& sampler) {
  return sampler.type == sampler_type::sobol ? sample1f(sampler.sobol)
                                             : rand1f(*sampler.rng);
}

static vec2f next2f(path_sampler& sampler) {
  return sampler.type == sampler_type::sobol ? sample2f(sampler.sobol)
                                             : rand2f(*sampler.rng);
}

// Path-length policy of shade_implicit (Yocto/GL's values).
inline constexpr int   max_opacity_skips    = 128;  // straight-through hits
inline constexpr int   roulette_min_bounce  = 3;    // roulette after this
inline constexpr float roulette_max_survive = 0.99f;

// The state of one path.
struct path_state {
  vec3f        radiance      = {0, 0, 0};
  vec3f        weight        = {1, 1, 1};
  ray3f        ray           = {};
  bool         hit           = false;
  int          opacity_skips = 0;
  volume_stack volumes       = {};
  // Two-sample MIS: the BSDF pdf of the direction that led here, or 0 when
  // emission found along it needs no weight (camera, delta, one-sample),
  // and the light context of the point it left (the light pdf of an emitter
  // it lands on is seen from there).
  float         bsdf_pdf = 0;
  light_context from     = {};
  // How lights are picked (the render's parameter).
  light_sampler_type light_sampler = light_sampler_type::bvh;
  // Whether the sample's albedo and normal are set (first non-specular hit).
  bool featured = false;
};

// The one sample/pdf/weight step: multiply the path weight by f / pdf.
// Returns false (the path ends) for a null direction or pdf.
static bool update_weight(
    path_state& path, vec3f incoming, vec3f f, float pdf) {
  if (incoming == vec3f{0, 0, 0} || pdf <= 0) return false;
  path.weight *= f / pdf;
  return true;
}

// MIS weight of the emission of accel object `object` reached by a
// BSDF-sampled direction: against the light sample of that object's light
// (1 for an emitter that is no light: nothing else samples it).
static float emission_weight(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const path_state& path, int object,
    vec3f direction) {
  if (path.bsdf_pdf <= 0) return 1;
  if (object < 0 || object >= (int)lights.object_lights.size()) return 1;
  auto light = lights.object_lights[object];
  if (light < 0) return 1;
  return power_heuristic(path.bsdf_pdf,
      sample_light_pdf(scene, accel, lights, path.from, light, direction));
}

// Radiance of the environments along a direction that escaped the scene,
// each weighted against its own light sample.
static vec3f escaped_radiance(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const path_state& path, vec3f direction) {
  if (path.bsdf_pdf <= 0) return eval_environment(scene, lights, direction);
  auto radiance = vec3f{0, 0, 0};
  for (auto k = lights.shapes; k < (int)lights.lights.size(); k++) {
    auto& light    = lights.lights[k];
    auto  emission = eval_environment_light(scene, lights, light, direction);
    if (emission == vec3f{0, 0, 0}) continue;
    auto lpdf = sample_light_pdf(scene, accel, lights, path.from, k, direction);
    radiance += emission * power_heuristic(path.bsdf_pdf, lpdf);
  }
  return radiance;
}

// Where light is wanted at a surface point: the normal on the side of
// `outgoing` for materials that only reflect (lights behind them get no
// samples), none for those that also transmit.
static light_context surface_light_context(
    const surface_point& point, vec3f outgoing, light_sampler_type sampler) {
  auto normal = is_reflective_only(point.material)
                    ? up_normal(point.normal, outgoing)
                    : vec3f{0, 0, 0};
  return {point.position, normal, sampler};
}

// A light sample (three numbers drawn in order).
static light_sample sample_lights_next(const scene_data& scene,
    const accel_data& accel, const lights_data& lights,
    const light_context& context, path_sampler& sampler) {
  auto rl  = next1f(sampler);
  auto rel = next1f(sampler);
  auto ruv = next2f(sampler);
  return sample_lights(scene, accel, lights, context, rl, rel, ruv);
}

// Scattering in a medium: one-sample mixture of the phase function and the
// lights. Returns false when the path ends.
static bool shade_medium(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, bool use_lights, path_state& path,
    vec3f position, path_sampler& sampler) {
  auto& medium   = path.volumes.items[path.volumes.size - 1];
  auto  outgoing = -path.ray.d;
  auto  incoming = vec3f{0, 0, 0};
  auto  context  = light_context{position, {0, 0, 0}, path.light_sampler};
  auto  rmix     = use_lights ? next1f(sampler) : 0.0f;
  if (rmix < 0.5f) {
    auto rl  = next1f(sampler);
    auto ru  = next2f(sampler);
    incoming = sample_scattering(medium, outgoing, rl, ru);
  } else {
    incoming =
        sample_lights_next(scene, accel, lights, context, sampler).direction;
  }
  if (incoming == vec3f{0, 0, 0}) return false;
  auto pdf = sample_scattering_pdf(medium, outgoing, incoming);
  if (use_lights)
    pdf = 0.5f * pdf +
          0.5f * sample_lights_pdf(scene, accel, lights, context, incoming);
  if (!update_weight(
          path, incoming, eval_scattering(medium, outgoing, incoming), pdf))
    return false;
  path.bsdf_pdf = 0;
  path.ray      = {position, incoming, 0, flt_max};
  return true;
}

// Delta lobes (mirror, glass, volumetric boundaries).
static vec3f shade_delta(
    path_state& path, const surface_point& point, path_sampler& sampler) {
  auto& material = point.material;
  auto  outgoing = -path.ray.d;
  auto  rl       = next1f(sampler);
  auto  incoming = sample_delta(material, point.normal, outgoing, rl);
  if (incoming == vec3f{0, 0, 0}) return incoming;
  auto pdf = sample_delta_pdf(material, point.normal, outgoing, incoming);
  if (!update_weight(path, incoming,
          eval_delta(material, point.normal, outgoing, incoming), pdf))
    return {0, 0, 0};
  // A volumetric boundary only lets the path through, and light samples see
  // through it too (eval_light): emission found beyond it keeps the MIS
  // weight of the sample that led here.
  if (material.type != material_type::volumetric) path.bsdf_pdf = 0;
  return incoming;
}

// Two-sample MIS: a light sample that counts its own light's emission along
// its direction, then a BSDF sample that continues the path, both weighted
// by the power heuristic (see sample_light_pdf() in lights.h for why each
// emitter is counted once). Never called at the last bounce, whose light
// sample would count a share of paths one bounce longer than one-sample MIS
// and the BSDF alone reach.
static vec3f shade_two_sample(const scene_data& scene, const accel_data& accel,
    const march_params& march, const lights_data& lights, path_state& path,
    const surface_point& point, path_sampler& sampler, int64_t& evaluations) {
  auto& material = point.material;
  auto  outgoing = -path.ray.d;
  auto  context  = surface_light_context(point, outgoing, path.light_sampler);
  auto  light    = sample_lights_next(scene, accel, lights, context, sampler);
  if (light.light >= 0) {
    auto bsdfcos =
        eval_bsdfcos(material, point.normal, outgoing, light.direction);
    if (bsdfcos != vec3f{0, 0, 0}) {
      auto bpdf =
          sample_bsdfcos_pdf(material, point.normal, outgoing, light.direction);
      auto le = eval_light(scene, accel, march, lights, light.light,
          spawn_ray(accel, march, point, light.direction), evaluations);
      path.radiance += path.weight * bsdfcos * le *
                       (power_heuristic(light.pdf, bpdf) / light.pdf);
    }
  }
  auto rl       = next1f(sampler);
  auto ru       = next2f(sampler);
  auto incoming = sample_bsdfcos(material, point.normal, outgoing, rl, ru);
  if (incoming == vec3f{0, 0, 0}) return incoming;
  auto pdf = sample_bsdfcos_pdf(material, point.normal, outgoing, incoming);
  if (!update_weight(path, incoming,
          eval_bsdfcos(material, point.normal, outgoing, incoming), pdf))
    return {0, 0, 0};
  path.bsdf_pdf = pdf;
  path.from     = context;
  return incoming;
}

// One-sample MIS (the seed's): the BSDF or the lights 50/50, weighted by the
// mixture pdf; BSDF sampling only without lights.
static vec3f shade_one_sample(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, bool use_lights, path_state& path,
    const surface_point& point, path_sampler& sampler) {
  auto& material = point.material;
  auto  outgoing = -path.ray.d;
  auto  incoming = vec3f{0, 0, 0};
  auto  context  = surface_light_context(point, outgoing, path.light_sampler);
  auto  rmix     = use_lights ? next1f(sampler) : 0.0f;
  if (rmix < 0.5f) {
    auto rl  = next1f(sampler);
    auto ru  = next2f(sampler);
    incoming = sample_bsdfcos(material, point.normal, outgoing, rl, ru);
  } else {
    incoming =
        sample_lights_next(scene, accel, lights, context, sampler).direction;
  }
  if (incoming == vec3f{0, 0, 0}) return incoming;
  auto pdf = sample_bsdfcos_pdf(material, point.normal, outgoing, incoming);
  if (use_lights)
    pdf = 0.5f * pdf +
          0.5f * sample_lights_pdf(scene, accel, lights, context, incoming);
  if (!update_weight(path, incoming,
          eval_bsdfcos(material, point.normal, outgoing, incoming), pdf))
    return {0, 0, 0};
  path.bsdf_pdf = 0;
  return incoming;
}

// Crossing the boundary of a closed medium enters or leaves it.
static void update_volumes(path_state& path, const surface_point& point,
    vec3f outgoing, vec3f incoming) {
  auto& material = point.material;
  if (!is_volumetric(material) ||
      dot(point.normal, outgoing) * dot(point.normal, incoming) >= 0)
    return;
  auto& volumes = path.volumes;
  if (dot(point.normal, incoming) < 0) {
    if (volumes.size < (int)volumes.items.size())
      volumes.items[volumes.size++] = material;
  } else if (volumes.size > 0) {
    volumes.size--;
  }
}

// What every bounce of one path reads.
struct path_context {
  const scene_data&   scene;
  const accel_data&   accel;
  const lights_data&  lights;
  const trace_params& params;
  bool                use_lights = false;  // light sampling at all
  bool                two_sample = false;  // two-sample MIS
};

// How a bounce ended: the path scattered (path.ray is the next ray), went
// straight through an opacity hit (no bounce), or ends.
enum class path_step { scatter, pass, stop };

// Inside a medium: a free-flight distance before the surface the ray hit;
// `isec.distance` becomes it, and `in_volume` tells whether it falls short
// of the surface. False: the path ends (no pdf).
static bool sample_free_flight(path_state& path, scene_intersection& isec,
    path_sampler& sampler, bool& in_volume) {
  auto& medium   = path.volumes.items[path.volumes.size - 1];
  auto  rd       = next1f(sampler);
  auto  rc       = next1f(sampler);
  auto  distance = sample_transmittance(medium.density, isec.distance, rd, rc);
  auto  pdf = sample_transmittance_pdf(medium.density, distance, isec.distance);
  if (pdf <= 0) return false;
  path.weight *= eval_transmittance(medium.density, distance) / pdf;
  in_volume     = distance < isec.distance;
  isec.distance = distance;
  return true;
}

// A scattering point inside the innermost medium.
static path_step shade_volume_point(const path_context& context,
    path_state& path, float distance, bool last, pixel_sample& features,
    path_sampler& sampler) {
  if (!path.featured) {
    features.albedo = path.volumes.items[path.volumes.size - 1].scattering;
    path.featured   = true;
  }
  if (last) return path_step::stop;
  auto position = ray_point(path.ray, distance);
  return shade_medium(context.scene, context.accel, context.lights,
             context.use_lights, path, position, sampler)
             ? path_step::scatter
             : path_step::stop;
}

// The first hit's features: position and depth of the first surface the
// camera sees, albedo and normal of the first non-specular one.
static void note_features(path_state& path, const surface_point& point,
    const ray3f& camera_ray, int bounce, pixel_sample& features) {
  if (bounce == 0 && !path.hit) {
    path.hit          = true;
    features.position = point.position;
    features.depth    = distance(camera_ray.o, point.position);
  }
  if (!path.featured && !is_delta(point.material)) {
    features.albedo = point.material.color;
    features.normal = point.normal;
    path.featured   = true;
  }
}

// The next direction from a surface point by the strategy of its material
// and the render's MIS; zero when the path ends.
static vec3f scatter_surface(const path_context& context, path_state& path,
    const surface_point& point, path_sampler& sampler, int64_t& evaluations) {
  if (is_delta(point.material)) return shade_delta(path, point, sampler);
  if (context.two_sample && path.volumes.size == 0) {
    // Inside a medium, two-sample MIS gives way to the one-sample mixture
    // (as shade_medium() does). A light sample from there would need the
    // transmittance of the medium it starts in, which eval_light() does not
    // know (it attenuates only the media it enters along its ray, and would
    // take the boundary it leaves by for an entry), and it could not cross
    // the refractive or subsurface boundary that closes most media (a delta
    // interface blocks it). The mixture follows the light direction as the
    // path itself, through free-flight sampling and the boundary, so it
    // stays unbiased: emission reached that way takes weight 1 (bsdf_pdf =
    // 0), the mixture pdf being already in the path weight.
    return shade_two_sample(context.scene, context.accel, context.params.march,
        context.lights, path, point, sampler, evaluations);
  }
  return shade_one_sample(context.scene, context.accel, context.lights,
      context.use_lights, path, point, sampler);
}

// A surface hit: opacity, features, the emission it lands on, and the next
// direction (none at the last bounce).
static path_step shade_surface_hit(const path_context& context,
    path_state& path, const scene_intersection& isec, const ray3f& camera_ray,
    int bounce, bool last, pixel_sample& features, path_sampler& sampler,
    int64_t& evaluations) {
  auto& scene = context.scene;
  auto& accel = context.accel;
  auto& march = context.params.march;
  // The last bounce needs neither the normal nor the textures of a surface
  // without emission that light can not pass (once the features are known:
  // the first hit of a path with one bounce gives them).
  if (last && path.featured &&
      blocks_without_emission(scene, accel.objects[isec.object]))
    return path_step::stop;
  auto  point    = eval_surface(scene, accel, path.ray, isec);
  auto  outgoing = -path.ray.d;
  auto& material = point.material;
  // Opacity: continue straight through (bounded, as Yocto does).
  if (material.opacity < 1) {
    auto ro = next1f(sampler);
    if (ro >= material.opacity) {
      if (path.opacity_skips++ > max_opacity_skips) return path_step::stop;
      path.ray = spawn_ray(accel, march, point, path.ray.d);
      return path_step::pass;
    }
  }
  note_features(path, point, camera_ray, bounce, features);
  // Most surfaces emit nothing: their MIS weight (a light pdf over every
  // light) is not needed.
  auto emission = eval_emission(material, point.normal, outgoing);
  auto mis      = emission == vec3f{0, 0, 0}
                      ? 1.0f
                      : emission_weight(scene, accel, context.lights, path,
                            isec.object, path.ray.d);
  path.radiance += path.weight * emission * mis;
  if (last) return path_step::stop;
  auto incoming = scatter_surface(context, path, point, sampler, evaluations);
  if (incoming == vec3f{0, 0, 0}) return path_step::stop;
  update_volumes(path, point, outgoing, incoming);
  path.ray = spawn_ray(accel, march, point, incoming);
  return path_step::scatter;
}

// Russian roulette after a few bounces; false: the path ends.
static bool survive_roulette(
    path_state& path, int bounce, path_sampler& sampler) {
  if (bounce <= roulette_min_bounce) return true;
  auto survive = std::min(roulette_max_survive, max(path.weight));
  auto rr      = next1f(sampler);
  if (rr >= survive) return false;
  path.weight /= survive;
  return true;
}

// Path tracer: per bounce, a free-flight sample inside media, then the
// strategy of the point reached (shade_medium, shade_delta, shade_two_sample,
// shade_one_sample), then Russian roulette. One-sample MIS collects emission
// where the path lands, so emitters that cannot be sampled are still found.
static vec4f shade_implicit(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const ray3f& camera_ray,
    const trace_params& params, path_sampler& sampler, pixel_sample& features,
    int64_t& evaluations) {
  auto use_lights    = params.implicit_mis && !lights.lights.empty();
  auto context       = path_context{scene, accel, lights, params, use_lights,
      use_lights && params.mis == mis_type::two_sample};
  auto path          = path_state{};
  path.ray           = camera_ray;
  path.light_sampler = params.light_sampler;
  // Straight-through opacity hits do not count as bounces.
  auto bounce = 0;
  while (bounce < params.bounces) {
    // The last bounce only collects the emission it lands on: the direction
    // it would scatter to is never traced.
    auto last = bounce + 1 == params.bounces;
    auto isec = intersect_scene(accel, params.march, path.ray);
    evaluations += isec.evaluations;
    if (!isec.hit) {
      if (bounce > 0 || !params.envhidden)
        path.radiance += path.weight * escaped_radiance(scene, accel, lights,
                                           path, path.ray.d);
      break;
    }
    auto in_volume = false;
    if (path.volumes.size > 0 &&
        !sample_free_flight(path, isec, sampler, in_volume))
      break;
    auto step = in_volume ? shade_volume_point(context, path, isec.distance,
                                last, features, sampler)
                          : shade_surface_hit(context, path, isec, camera_ray,
                                bounce, last, features, sampler, evaluations);
    if (step == path_step::stop) break;
    if (step == path_step::pass) continue;
    if (max(path.weight) <= 0 || !isfinite(path.weight)) break;
    if (!survive_roulette(path, bounce, sampler)) break;
    bounce++;
  }
  auto& radiance = path.radiance;
  return {radiance.x, radiance.y, radiance.z, path.hit ? 1.0f : 0.0f};
}

// Colour ramp for the steps heat map: blue (few) -> red (many), log scale.
static vec3f heat_color(float value) {
  auto v = clamp(value, 0.0f, 1.0f);
  return {clamp(2 * v - 0.5f, 0.0f, 1.0f),
      clamp(1 - std::abs(2 * v - 1), 0.0f, 1.0f),
      clamp(1.5f - 2 * v, 0.0f, 1.0f)};
}

// Debug shaders: one intersection, a value of the first hit.
static vec4f shade_debug(const scene_data& scene, const accel_data& accel,
    const ray3f& ray, const trace_params& params, pixel_sample& features,
    int64_t& evaluations) {
  auto isec = intersect_scene(accel, params.march, ray);
  evaluations += isec.evaluations;
  if (params.shader == shader_type::steps) {
    auto scale = std::log2(1.0f + (float)params.march.max_iterations);
    auto color = heat_color(std::log2(1.0f + isec.evaluations) / scale);
    return {color.x, color.y, color.z, 1};
  }
  if (!isec.hit) return {0, 0, 0, 0};
  auto point        = eval_surface(scene, accel, ray, isec);
  auto outgoing     = -ray.d;
  features.albedo   = point.material.color;
  features.normal   = point.normal;
  features.position = point.position;
  features.depth    = distance(ray.o, point.position);
  auto color        = vec3f{0, 0, 0};
  switch (params.shader) {
    case shader_type::implicit_normal:
    case shader_type::normal: color = point.normal * 0.5f + 0.5f; break;
    case shader_type::position: color = point.position; break;
    case shader_type::color: color = point.material.color; break;
    case shader_type::frontfacing:
      color =
          dot(point.normal, outgoing) >= 0 ? vec3f{0, 1, 0} : vec3f{1, 0, 0};
      break;
    case shader_type::material: {
      // A distinct hue per material index.
      auto h = std::fmod(accel.objects[isec.object].material * 0.618034f, 1.0f);
      color  = heat_color(h);
      break;
    }
    case shader_type::eyelight: {
      auto& material = point.material;
      color          = eval_emission(material, point.normal, outgoing);
      if (!is_delta(material))
        color += pif * eval_bsdfcos(material, point.normal, outgoing, outgoing);
      break;
    }
    case shader_type::implicit:
    case shader_type::steps: break;
  }
  return {color.x, color.y, color.z, 1};
}

bool is_lit_shader(shader_type shader) {
  return shader == shader_type::implicit;
}

// -----------------------------------------------------------------------------
// SAMPLES
// -----------------------------------------------------------------------------

// Offset inside a pixel for a tent filter of width 2 pixels (Yocto/GL).
static float tent_offset(float r) {
  return r < 0.5f ? std::sqrt(2 * r) - 1 : 1 - std::sqrt(2 - 2 * r);
}

pixel_sample trace_sample(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const camera_data& camera,
    const trace_params& params, vec2i ij, vec2i size, int sample,
    rng_state& rng, int64_t& evaluations, float start) {
  auto [i, j]  = ij;
  auto sampler = path_sampler{params.sampler, {}, &rng};
  if (params.sampler == sampler_type::sobol) {
    auto seed =
        hash_uint32((uint32_t)params.seed ^ (uint32_t)(params.seed >> 32));
    sampler.sobol = make_sobol(
        hash_combine(seed, (uint32_t)(j * size.x + i)), (uint32_t)sample);
  }
  auto puv = next2f(sampler);
  if (params.tentfilter)
    puv = vec2f{tent_offset(puv.x), tent_offset(puv.y)} + vec2f{0.5f, 0.5f};
  auto uv = vec2f{(i + puv.x) / size.x, (j + puv.y) / size.y};
  // The lens sample is drawn only for cameras that use it (pinholes skip
  // the warp, as it costs a sizeable part of a camera ray).
  auto lens = camera.aperture > 0 ? sample_disk(next2f(sampler)) : vec2f{0, 0};
  auto ray  = eval_camera(camera, uv, lens);
  ray.tmin  = start;
  auto result = pixel_sample{};
  auto color =
      params.shader == shader_type::implicit
          ? shade_implicit(
                scene, accel, lights, ray, params, sampler, result, evaluations)
          : shade_debug(scene, accel, ray, params, result, evaluations);
  auto rgb = xyz(color);
  if (!isfinite(rgb)) rgb = {0, 0, 0};
  if (max(rgb) > params.clamp) rgb = rgb * (params.clamp / max(rgb));
  // Without envhidden the environment counts as coverage.
  auto alpha = color.w;
  if (params.shader == shader_type::implicit && !params.envhidden &&
      !scene.environments.empty())
    alpha = 1;
  result.color = {rgb.x, rgb.y, rgb.z, alpha};
  return result;
}

}  // namespace implicit
