// # implicit: shading
//
// The material model of Yocto/GL 4.2 (`yocto_shading.h` lobes, `eval_material`
// and the `eval_bsdfcos` family of `yocto_trace.cpp`): one eval/sample/pdf
// triple per lobe, then dispatch functions that `switch` on the material type.
//
// Conventions, as in Yocto/GL:
// - `eval_*` return BSDF * |cos(normal, incoming)|; `sample_*` return a
//   direction (zero when the sample is rejected); `sample_*_pdf` return a
//   solid-angle pdf (delta lobes: the probability of the discrete choice);
// - `outgoing` and `incoming` point away from the surface;
// - `normal` is NOT flipped toward the viewer: two-sided lobes use
//   up_normal = dot(normal, outgoing) <= 0 ? -normal : normal;
// - roughness is the GGX alpha (the material's roughness already squared).
//
// Deliberate differences from Yocto/GL 4.2, each marked where it happens:
// - rough refraction: the pdf has the factor rel_ior^2 of the half-vector
//   Jacobian (Walter et al. 2007, eq. 17) that Yocto drops, and back-facing
//   microfacets neither refract nor count in the pdf (as in pbrt-v4). Only
//   then is the pdf the density of the directions `sample_refractive` draws
//   (the chi-square test in shading_test.cpp rejects Yocto's pdf); the
//   discarded samples have eval 0 in Yocto too;
// - subsurface with roughness 0 is a delta refractive surface (Yocto makes it
//   neither delta nor rough, so it renders black);
// - refractive and subsurface with ior 1 are the delta pass-through whatever
//   their roughness (the rough lobe sends every refracted sample to exactly
//   -outgoing, which no pdf describes);
// - directions exactly on the horizon give 0 instead of 0/0 = NaN, and
//   Fresnel terms are kept >= 0 against rounding.
//
// Everything here is inline, allocation-free and never throws.
#pragma once

#include <cmath>

#include "../math/math.h"
#include "../math/sampling.h"
#include "../scene/scene.h"

namespace implicit {

// -----------------------------------------------------------------------------
// MATERIAL POINT
// -----------------------------------------------------------------------------

// Smallest roughness (as GGX alpha, i.e. squared) of a non-delta lobe.
inline constexpr float min_roughness = 0.03f * 0.03f;

// Below this distance from 1, an index of refraction is no interface.
inline constexpr float index_matched_eps = 1e-3f;

// Material at a surface point, ready for shading (roughness already squared).
struct material_point {
  material_type type         = material_type::matte;
  vec3f         emission     = {0, 0, 0};
  vec3f         color        = {0, 0, 0};
  float         opacity      = 1;
  float         roughness    = 0;
  float         metallic     = 0;
  float         ior          = 1.5f;
  vec3f         density      = {0, 0, 0};
  vec3f         scattering   = {0, 0, 0};
  float         scanisotropy = 0;
  float         trdepth      = 0.01f;
};

// Material point from a material and its already looked-up texel values
// (Yocto/GL's eval_material; roughness texels use the glTF layout: y is
// roughness, z is metallic).
inline material_point make_material_point(const material_data& material,
    vec4f color_texel = {1, 1, 1, 1}, vec4f emission_texel = {1, 1, 1, 1},
    vec4f roughness_texel  = {1, 1, 1, 1},
    vec4f scattering_texel = {1, 1, 1, 1}) {
  auto point         = material_point{};
  point.type         = material.type;
  point.emission     = material.emission * xyz(emission_texel);
  point.color        = material.color * xyz(color_texel);
  point.opacity      = material.opacity * color_texel.w;
  point.metallic     = material.metallic * roughness_texel.z;
  point.roughness    = material.roughness * roughness_texel.y;
  point.roughness    = point.roughness * point.roughness;
  point.ior          = material.ior;
  point.scattering   = material.scattering * xyz(scattering_texel);
  point.scanisotropy = material.scanisotropy;
  point.trdepth      = material.trdepth;

  // Volumes: the color is the transmission after trdepth (Beer-Lambert).
  if (material.type == material_type::refractive ||
      material.type == material_type::volumetric ||
      material.type == material_type::subsurface) {
    point.density = -log(clamp(point.color, 0.0001f, 1.0f)) / point.trdepth;
  } else {
    point.density = {0, 0, 0};
  }

  // Diffuse-based lobes are never delta; the others become delta when too
  // smooth for GGX to be sampled reliably in float.
  if (material.type == material_type::matte ||
      material.type == material_type::gltfpbr ||
      material.type == material_type::glossy) {
    point.roughness = clamp(point.roughness, min_roughness, 1.0f);
  } else if (material.type == material_type::volumetric) {
    point.roughness = 0;
  } else if (point.roughness < min_roughness) {
    point.roughness = 0;
  }
  // An interface with index 1 does not bend light, so its roughness has no
  // effect: make it the delta pass-through of eval_refractive_delta (the rough
  // lobe would refract every sample to exactly -outgoing, which no pdf
  // describes). Not in Yocto/GL.
  if ((material.type == material_type::refractive ||
          material.type == material_type::subsurface) &&
      std::abs(material.ior - 1) < index_matched_eps) {
    point.roughness = 0;
  }
  return point;
}

// Whether the material scatters only in discrete directions.
inline bool is_delta(const material_point& material) {
  switch (material.type) {
    case material_type::matte:
    case material_type::glossy:
    case material_type::gltfpbr: return false;
    case material_type::reflective:
    case material_type::transparent:
    case material_type::refractive:
    // Not in Yocto 4.2, which leaves smooth subsurface black.
    case material_type::subsurface: return material.roughness == 0;
    case material_type::volumetric: return true;
  }
  return false;
}

// Whether the material scatters only to the side light comes from (no
// transmission): light behind its surface cannot reach the viewer.
inline bool is_reflective_only(const material_point& material) {
  switch (material.type) {
    case material_type::matte:
    case material_type::glossy:
    case material_type::reflective:
    case material_type::gltfpbr: return true;
    case material_type::transparent:
    case material_type::refractive:
    case material_type::subsurface:
    case material_type::volumetric: return false;
  }
  return false;
}

// Whether the material encloses a participating medium.
inline bool is_volumetric(const material_point& material) {
  return material.type == material_type::refractive ||
         material.type == material_type::volumetric ||
         material.type == material_type::subsurface;
}

// -----------------------------------------------------------------------------
// FRESNEL
// -----------------------------------------------------------------------------

// Normal flipped to the side of `outgoing` (lobes are two-sided).
inline vec3f up_normal(vec3f normal, vec3f outgoing) {
  return dot(normal, outgoing) <= 0 ? -normal : normal;
}

// Whether two directions lie on the same side of the surface.
inline bool same_hemisphere(vec3f normal, vec3f outgoing, vec3f incoming) {
  return dot(normal, outgoing) * dot(normal, incoming) >= 0;
}

// Whether either direction lies exactly in the tangent plane, where the
// microfacet terms below become 0/0.
inline bool on_horizon(vec3f normal, vec3f outgoing, vec3f incoming) {
  return dot(normal, outgoing) == 0 || dot(normal, incoming) == 0;
}

// Schlick's approximation of the Fresnel term.
inline vec3f fresnel_schlick(vec3f specular, vec3f normal, vec3f outgoing) {
  if (specular == vec3f{0, 0, 0}) return {0, 0, 0};
  auto cosine = dot(normal, outgoing);
  return specular + (vec3f{1, 1, 1} - specular) *
                        std::pow(clamp(1 - std::abs(cosine), 0.0f, 1.0f), 5.0f);
}

// Unpolarized Fresnel reflectance of a dielectric with relative index `eta`
// (Lagarde, "Memo on Fresnel equations", 2013); 1 under total internal
// reflection.
inline float fresnel_dielectric(float eta, vec3f normal, vec3f outgoing) {
  auto cosw  = std::abs(dot(normal, outgoing));
  auto sin2  = 1 - cosw * cosw;
  auto eta2  = eta * eta;
  auto cos2t = 1 - sin2 / eta2;
  // Grazing is the limit 1; computed, it is 0/0 when eta == 1.
  if (cos2t < 0 || cosw == 0) return 1;
  auto t0 = std::sqrt(cos2t);
  auto t1 = eta * t0;
  auto t2 = eta * cosw;
  auto rs = (cosw - t1) / (cosw + t1);
  auto rp = (t0 - t2) / (t0 + t2);
  return (rs * rs + rp * rp) / 2;
}

// Unpolarized Fresnel reflectance of a conductor with complex index
// eta + i etak (Lagarde 2013); 0 from below the surface.
inline vec3f fresnel_conductor(
    vec3f eta, vec3f etak, vec3f normal, vec3f outgoing) {
  auto cosw = dot(normal, outgoing);
  if (cosw <= 0) return {0, 0, 0};
  cosw          = clamp(cosw, -1.0f, 1.0f);
  auto cos2     = cosw * cosw;
  auto sin2     = clamp(1 - cos2, 0.0f, 1.0f);
  auto eta2     = eta * eta;
  auto etak2    = etak * etak;
  auto t0       = eta2 - etak2 - sin2;
  auto a2plusb2 = sqrt(t0 * t0 + 4 * eta2 * etak2);
  auto t1       = a2plusb2 + cos2;
  auto a        = sqrt((a2plusb2 + t0) / 2);
  auto t2       = 2 * a * cosw;
  auto rs       = (t1 - t2) / (t1 + t2);
  auto t3       = cos2 * a2plusb2 + sin2 * sin2;
  auto t4       = t2 * sin2;
  auto rp       = rs * (t3 - t4) / (t3 + t4);
  // rs and rp are squares, (a - cos)^2 / (a + cos)^2 and alike, but t1 - t2
  // rounds below 0 when eta ~ 1 and etak ~ 0 (a black conductor).
  return max((rp + rs) / 2, 0.0f);
}

// Reflectance at normal incidence of a dielectric with index `eta`.
inline vec3f eta_to_reflectivity(vec3f eta) {
  return ((eta - 1) * (eta - 1)) / ((eta + 1) * (eta + 1));
}

// Index of refraction with the given reflectance at normal incidence; the
// reflectance is clamped to 0.99 to keep the index finite.
inline vec3f reflectivity_to_eta(vec3f reflectivity) {
  auto r = sqrt(clamp(reflectivity, 0.0f, 0.99f));
  return (r + 1) / (vec3f{1, 1, 1} - r);
}

// -----------------------------------------------------------------------------
// MICROFACETS (GGX, Walter et al. 2007)
// -----------------------------------------------------------------------------

// GGX normal distribution D(halfway), with roughness as alpha.
inline float microfacet_distribution(
    float roughness, vec3f normal, vec3f halfway) {
  auto cosine = dot(normal, halfway);
  if (cosine <= 0) return 0;
  auto roughness2 = roughness * roughness;
  auto cosine2    = cosine * cosine;
  auto denom      = cosine2 * roughness2 + 1 - cosine2;
  return roughness2 / (pif * denom * denom);
}

// Smith's GGX masking term G1 for one direction.
inline float microfacet_shadowing1(
    float roughness, vec3f normal, vec3f halfway, vec3f direction) {
  auto cosine  = dot(normal, direction);
  auto cosineh = dot(halfway, direction);
  if (cosine * cosineh <= 0) return 0;
  auto roughness2 = roughness * roughness;
  auto cosine2    = cosine * cosine;
  return 2 * std::abs(cosine) /
         (std::abs(cosine) +
             std::sqrt(cosine2 - roughness2 * cosine2 + roughness2));
}

// Separable Smith masking-shadowing G = G1(outgoing) G1(incoming).
inline float microfacet_shadowing(float roughness, vec3f normal, vec3f halfway,
    vec3f outgoing, vec3f incoming) {
  return microfacet_shadowing1(roughness, normal, halfway, outgoing) *
         microfacet_shadowing1(roughness, normal, halfway, incoming);
}

// Half vector distributed as D(h) cos(n, h).
inline vec3f sample_microfacet(float roughness, vec3f normal, vec2f rn) {
  auto phi   = 2 * pif * rn.x;
  auto theta = std::atan(roughness * std::sqrt(rn.y / (1 - rn.y)));
  auto local = vec3f{std::cos(phi) * std::sin(theta),
      std::sin(phi) * std::sin(theta), std::cos(theta)};
  return transform_direction(basis_fromz(normal), local);
}

// Pdf of sample_microfacet (over half-vector solid angle).
inline float sample_microfacet_pdf(
    float roughness, vec3f normal, vec3f halfway) {
  auto cosine = dot(normal, halfway);
  if (cosine < 0) return 0;
  return microfacet_distribution(roughness, normal, halfway) * cosine;
}

// Specular microfacet reflection without Fresnel, times |cos(n, incoming)|:
// D G / (4 |n.o| |n.i|) |n.i|. Callers check that both lie above `normal`.
inline float eval_microfacet_reflection(float roughness, vec3f normal,
    vec3f halfway, vec3f outgoing, vec3f incoming) {
  auto D = microfacet_distribution(roughness, normal, halfway);
  auto G = microfacet_shadowing(roughness, normal, halfway, outgoing, incoming);
  return D * G / (4 * std::abs(dot(normal, outgoing)));
}

// Pdf of reflecting `outgoing` about a sampled half vector: the half-vector
// pdf times the Jacobian 1 / (4 |o.h|).
inline float sample_microfacet_reflection_pdf(
    float roughness, vec3f normal, vec3f outgoing, vec3f incoming) {
  auto halfway = normalize(outgoing + incoming);
  return sample_microfacet_pdf(roughness, normal, halfway) /
         (4 * std::abs(dot(outgoing, halfway)));
}

// Reflection of `outgoing` about a sampled half vector; zero if it goes
// through the surface.
inline vec3f sample_microfacet_reflection(
    float roughness, vec3f normal, vec3f outgoing, vec2f rn) {
  auto halfway  = sample_microfacet(roughness, normal, rn);
  auto incoming = reflect(outgoing, halfway);
  if (!same_hemisphere(normal, outgoing, incoming)) return {0, 0, 0};
  return incoming;
}

// -----------------------------------------------------------------------------
// MATTE
// -----------------------------------------------------------------------------

// Lambertian reflection.
inline vec3f eval_matte(
    vec3f color, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return {0, 0, 0};
  return color / pif * std::abs(dot(normal, incoming));
}

// Cosine-weighted direction on the side of `outgoing`.
inline vec3f sample_matte(vec3f normal, vec3f outgoing, vec2f rn) {
  return sample_hemisphere_cos(up_normal(normal, outgoing), rn);
}

// Pdf of sample_matte.
inline float sample_matte_pdf(vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return 0;
  return sample_hemisphere_cos_pdf(up_normal(normal, outgoing), incoming);
}

// -----------------------------------------------------------------------------
// GLOSSY (diffuse base under a white dielectric GGX coat)
// -----------------------------------------------------------------------------

// Diffuse weighted by the transmitted fraction 1 - F(outgoing) plus a white
// GGX reflection.
inline vec3f eval_glossy(vec3f color, float ior, float roughness, vec3f normal,
    vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return {0, 0, 0};
  auto up      = up_normal(normal, outgoing);
  auto F1      = fresnel_dielectric(ior, up, outgoing);
  auto halfway = normalize(incoming + outgoing);
  auto F       = fresnel_dielectric(ior, halfway, incoming);
  return color * (1 - F1) / pif * std::abs(dot(up, incoming)) +
         vec3f{1, 1, 1} * F *
             eval_microfacet_reflection(
                 roughness, up, halfway, outgoing, incoming);
}

// GGX reflection with probability F(outgoing), else cosine hemisphere.
inline vec3f sample_glossy(float ior, float roughness, vec3f normal,
    vec3f outgoing, float rnl, vec2f rn) {
  auto up = up_normal(normal, outgoing);
  if (rnl < fresnel_dielectric(ior, up, outgoing)) {
    return sample_microfacet_reflection(roughness, up, outgoing, rn);
  } else {
    return sample_hemisphere_cos(up, rn);
  }
}

// Pdf of sample_glossy.
inline float sample_glossy_pdf(
    float ior, float roughness, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return 0;
  auto up = up_normal(normal, outgoing);
  auto F  = fresnel_dielectric(ior, up, outgoing);
  return F * sample_microfacet_reflection_pdf(
                 roughness, up, outgoing, incoming) +
         (1 - F) * sample_hemisphere_cos_pdf(up, incoming);
}

// -----------------------------------------------------------------------------
// REFLECTIVE (conductor with normal-incidence reflectance `color`)
// -----------------------------------------------------------------------------

// Rough conductor: F D G / (4 |n.o| |n.i|) |n.i|.
inline vec3f eval_reflective(vec3f color, float roughness, vec3f normal,
    vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return {0, 0, 0};
  auto up      = up_normal(normal, outgoing);
  auto halfway = normalize(incoming + outgoing);
  auto F       = fresnel_conductor(
            reflectivity_to_eta(color), {0, 0, 0}, halfway, incoming);
  return F *
         eval_microfacet_reflection(roughness, up, halfway, outgoing, incoming);
}

// GGX half-vector reflection.
inline vec3f sample_reflective(
    float roughness, vec3f normal, vec3f outgoing, vec2f rn) {
  return sample_microfacet_reflection(
      roughness, up_normal(normal, outgoing), outgoing, rn);
}

// Pdf of sample_reflective.
inline float sample_reflective_pdf(
    float roughness, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return 0;
  return sample_microfacet_reflection_pdf(
      roughness, up_normal(normal, outgoing), outgoing, incoming);
}

// Smooth conductor: the Fresnel term at the mirror direction.
inline vec3f eval_reflective_delta(
    vec3f color, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return {0, 0, 0};
  return fresnel_conductor(reflectivity_to_eta(color), {0, 0, 0},
      up_normal(normal, outgoing), outgoing);
}

// Mirror direction.
inline vec3f sample_reflective_delta(vec3f normal, vec3f outgoing) {
  return reflect(outgoing, up_normal(normal, outgoing));
}

// Probability of the mirror direction.
inline float sample_reflective_delta_pdf(
    vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return 0;
  return 1;
}

// -----------------------------------------------------------------------------
// TRANSPARENT (thin dielectric sheet: transmission without bending)
// -----------------------------------------------------------------------------

// Rough thin sheet: white GGX reflection on the side of `outgoing`; through
// the sheet, color (1 - F) times the same lobe at the incoming direction
// mirrored back across the surface.
inline vec3f eval_transparent(vec3f color, float ior, float roughness,
    vec3f normal, vec3f outgoing, vec3f incoming) {
  if (on_horizon(normal, outgoing, incoming)) return {0, 0, 0};
  auto up = up_normal(normal, outgoing);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    auto halfway = normalize(incoming + outgoing);
    auto F       = fresnel_dielectric(ior, halfway, outgoing);
    return vec3f{1, 1, 1} * F *
           eval_microfacet_reflection(
               roughness, up, halfway, outgoing, incoming);
  } else {
    auto reflected = reflect(-incoming, up);
    auto halfway   = normalize(reflected + outgoing);
    auto F         = fresnel_dielectric(ior, halfway, outgoing);
    return color * (1 - F) *
           eval_microfacet_reflection(
               roughness, up, halfway, outgoing, reflected);
  }
}

// Samples a half vector, then reflects with probability F(halfway), else
// reflects and mirrors the result through the sheet.
inline vec3f sample_transparent(float ior, float roughness, vec3f normal,
    vec3f outgoing, float rnl, vec2f rn) {
  auto up        = up_normal(normal, outgoing);
  auto halfway   = sample_microfacet(roughness, up, rn);
  auto reflected = reflect(outgoing, halfway);
  if (rnl < fresnel_dielectric(ior, halfway, outgoing)) {
    if (!same_hemisphere(up, outgoing, reflected)) return {0, 0, 0};
    return reflected;
  } else {
    auto incoming = -reflect(reflected, up);
    if (same_hemisphere(up, outgoing, incoming)) return {0, 0, 0};
    return incoming;
  }
}

// Pdf of sample_transparent (the mirror through the sheet keeps solid angle).
inline float sample_transparent_pdf(
    float ior, float roughness, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (on_horizon(normal, outgoing, incoming)) return 0;
  auto up = up_normal(normal, outgoing);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    auto halfway = normalize(incoming + outgoing);
    return fresnel_dielectric(ior, halfway, outgoing) *
           sample_microfacet_reflection_pdf(roughness, up, outgoing, incoming);
  } else {
    auto reflected = reflect(-incoming, up);
    auto halfway   = normalize(reflected + outgoing);
    return (1 - fresnel_dielectric(ior, halfway, outgoing)) *
           sample_microfacet_reflection_pdf(roughness, up, outgoing, reflected);
  }
}

// Smooth thin sheet: white F reflected, color (1 - F) straight through.
inline vec3f eval_transparent_delta(
    vec3f color, float ior, vec3f normal, vec3f outgoing, vec3f incoming) {
  auto up = up_normal(normal, outgoing);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    return vec3f{1, 1, 1} * fresnel_dielectric(ior, up, outgoing);
  } else {
    return color * (1 - fresnel_dielectric(ior, up, outgoing));
  }
}

// Mirror direction with probability F, else straight through.
inline vec3f sample_transparent_delta(
    float ior, vec3f normal, vec3f outgoing, float rnl) {
  auto up = up_normal(normal, outgoing);
  if (rnl < fresnel_dielectric(ior, up, outgoing)) {
    return reflect(outgoing, up);
  } else {
    return -outgoing;
  }
}

// Probability of the reflected or the transmitted direction.
inline float sample_transparent_delta_pdf(
    float ior, vec3f normal, vec3f outgoing, vec3f incoming) {
  auto up = up_normal(normal, outgoing);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    return fresnel_dielectric(ior, up, outgoing);
  } else {
    return 1 - fresnel_dielectric(ior, up, outgoing);
  }
}

// -----------------------------------------------------------------------------
// REFRACTIVE (interface of a dielectric solid; the inside is behind `normal`)
// -----------------------------------------------------------------------------

// Generalized half vector of a refraction between `outgoing` (outside when
// entering) and `incoming`, oriented like up_normal (Walter et al. 2007,
// eq. 16); zero when degenerate (rel_ior 1 and incoming == -outgoing).
inline vec3f refraction_halfway(
    float rel_ior, bool entering, vec3f outgoing, vec3f incoming) {
  return -normalize(rel_ior * incoming + outgoing) * (entering ? 1.0f : -1.0f);
}

// Rough dielectric interface: white F-weighted GGX reflection and the
// Walter 2007 (eq. 21) transmission, with the 1/rel_ior^2 radiance scaling.
inline vec3f eval_refractive(
    float ior, float roughness, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (on_horizon(normal, outgoing, incoming)) return {0, 0, 0};
  auto entering = dot(normal, outgoing) >= 0;
  auto up       = entering ? normal : -normal;
  auto rel_ior  = entering ? ior : (1 / ior);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    auto halfway = normalize(incoming + outgoing);
    auto F       = fresnel_dielectric(rel_ior, halfway, outgoing);
    return vec3f{1, 1, 1} * F *
           eval_microfacet_reflection(
               roughness, up, halfway, outgoing, incoming);
  } else {
    auto halfway = refraction_halfway(rel_ior, entering, outgoing, incoming);
    if (halfway == vec3f{0, 0, 0}) return {0, 0, 0};
    auto F = fresnel_dielectric(rel_ior, halfway, outgoing);
    auto D = microfacet_distribution(roughness, up, halfway);
    auto G = microfacet_shadowing(roughness, up, halfway, outgoing, incoming);
    auto denom = rel_ior * dot(halfway, incoming) + dot(halfway, outgoing);
    return vec3f{1, 1, 1} *
           std::abs((dot(outgoing, halfway) * dot(incoming, halfway)) /
                    (dot(outgoing, normal) * dot(incoming, normal))) *
           (1 - F) * D * G / (denom * denom) * std::abs(dot(normal, incoming));
  }
}

// Samples a half vector, then reflects with probability F(halfway), else
// refracts through it.
inline vec3f sample_refractive(float ior, float roughness, vec3f normal,
    vec3f outgoing, float rnl, vec2f rn) {
  auto entering = dot(normal, outgoing) >= 0;
  auto up       = entering ? normal : -normal;
  auto rel_ior  = entering ? ior : (1 / ior);
  auto halfway  = sample_microfacet(roughness, up, rn);
  // A microfacet facing away from `outgoing` is masked (G1 = 0); refracting
  // through it leaving the inside gives a direction whose generalized half
  // vector is -halfway, which the pdf cannot account for. Not in Yocto/GL.
  if (dot(outgoing, halfway) <= 0) return {0, 0, 0};
  if (rnl < fresnel_dielectric(rel_ior, halfway, outgoing)) {
    auto incoming = reflect(outgoing, halfway);
    if (!same_hemisphere(up, outgoing, incoming)) return {0, 0, 0};
    return incoming;
  } else {
    auto incoming = refract(outgoing, halfway, 1 / rel_ior);
    if (same_hemisphere(up, outgoing, incoming)) return {0, 0, 0};
    return incoming;
  }
}

// Pdf of sample_refractive. The transmitted branch is the half-vector pdf
// times dh/di = rel_ior^2 |i.h| / (rel_ior i.h + o.h)^2 (Walter et al. 2007,
// eq. 17); Yocto/GL 4.2 omits rel_ior^2, which makes its pdf disagree with its
// own sampling by that factor.
inline float sample_refractive_pdf(
    float ior, float roughness, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (on_horizon(normal, outgoing, incoming)) return 0;
  auto entering = dot(normal, outgoing) >= 0;
  auto up       = entering ? normal : -normal;
  auto rel_ior  = entering ? ior : (1 / ior);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    auto halfway = normalize(incoming + outgoing);
    return fresnel_dielectric(rel_ior, halfway, outgoing) *
           sample_microfacet_reflection_pdf(roughness, up, outgoing, incoming);
  } else {
    auto halfway = refraction_halfway(rel_ior, entering, outgoing, incoming);
    // Only microfacets with `outgoing` in front and `incoming` behind refract
    // between them (pbrt-v4 discards the others too; Yocto/GL does not, so
    // its pdf has mass where its sampling never goes).
    if (dot(outgoing, halfway) <= 0 || dot(incoming, halfway) >= 0) return 0;
    auto denom = rel_ior * dot(halfway, incoming) + dot(halfway, outgoing);
    return (1 - fresnel_dielectric(rel_ior, halfway, outgoing)) *
           sample_microfacet_pdf(roughness, up, halfway) * rel_ior * rel_ior *
           std::abs(dot(halfway, incoming)) / (denom * denom);
  }
}

// Smooth dielectric interface: F reflected, (1 - F) / rel_ior^2 refracted;
// an index of 1 is no interface at all.
inline vec3f eval_refractive_delta(
    float ior, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (std::abs(ior - 1) < index_matched_eps) {
    return dot(normal, incoming) * dot(normal, outgoing) <= 0 ? vec3f{1, 1, 1}
                                                              : vec3f{0, 0, 0};
  }
  auto entering = dot(normal, outgoing) >= 0;
  auto up       = entering ? normal : -normal;
  auto rel_ior  = entering ? ior : (1 / ior);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    return vec3f{1, 1, 1} * fresnel_dielectric(rel_ior, up, outgoing);
  } else {
    return vec3f{1, 1, 1} * (1 / (rel_ior * rel_ior)) *
           (1 - fresnel_dielectric(rel_ior, up, outgoing));
  }
}

// Mirror direction with probability F, else the Snell direction.
inline vec3f sample_refractive_delta(
    float ior, vec3f normal, vec3f outgoing, float rnl) {
  if (std::abs(ior - 1) < index_matched_eps) return -outgoing;
  auto entering = dot(normal, outgoing) >= 0;
  auto up       = entering ? normal : -normal;
  auto rel_ior  = entering ? ior : (1 / ior);
  if (rnl < fresnel_dielectric(rel_ior, up, outgoing)) {
    return reflect(outgoing, up);
  } else {
    return refract(outgoing, up, 1 / rel_ior);
  }
}

// Probability of the reflected or the refracted direction.
inline float sample_refractive_delta_pdf(
    float ior, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (std::abs(ior - 1) < index_matched_eps) {
    return dot(normal, incoming) * dot(normal, outgoing) < 0 ? 1.0f : 0.0f;
  }
  auto entering = dot(normal, outgoing) >= 0;
  auto up       = entering ? normal : -normal;
  auto rel_ior  = entering ? ior : (1 / ior);
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) {
    return fresnel_dielectric(rel_ior, up, outgoing);
  } else {
    return 1 - fresnel_dielectric(rel_ior, up, outgoing);
  }
}

// -----------------------------------------------------------------------------
// GLTFPBR (glTF metallic-roughness with Schlick's Fresnel)
// -----------------------------------------------------------------------------

// Normal-incidence reflectance: 0.04 for ior 1.5 dielectrics, `color` for
// metals.
inline vec3f gltfpbr_reflectivity(vec3f color, float ior, float metallic) {
  return lerp(eta_to_reflectivity(vec3f{ior, ior, ior}), color, metallic);
}

// Diffuse color (1 - metallic)(1 - F(outgoing)) plus Schlick GGX reflection.
inline vec3f eval_gltfpbr(vec3f color, float ior, float roughness,
    float metallic, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return {0, 0, 0};
  auto reflectivity = gltfpbr_reflectivity(color, ior, metallic);
  auto up           = up_normal(normal, outgoing);
  auto F1           = fresnel_schlick(reflectivity, up, outgoing);
  auto halfway      = normalize(incoming + outgoing);
  auto F            = fresnel_schlick(reflectivity, halfway, incoming);
  return color * (1 - metallic) * (vec3f{1, 1, 1} - F1) / pif *
             std::abs(dot(up, incoming)) +
         F * eval_microfacet_reflection(
                 roughness, up, halfway, outgoing, incoming);
}

// GGX reflection with probability mean(F(outgoing)), else cosine hemisphere.
inline vec3f sample_gltfpbr(vec3f color, float ior, float roughness,
    float metallic, vec3f normal, vec3f outgoing, float rnl, vec2f rn) {
  auto up           = up_normal(normal, outgoing);
  auto reflectivity = gltfpbr_reflectivity(color, ior, metallic);
  if (rnl < mean(fresnel_schlick(reflectivity, up, outgoing))) {
    return sample_microfacet_reflection(roughness, up, outgoing, rn);
  } else {
    return sample_hemisphere_cos(up, rn);
  }
}

// Pdf of sample_gltfpbr.
inline float sample_gltfpbr_pdf(vec3f color, float ior, float roughness,
    float metallic, vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) <= 0) return 0;
  auto up           = up_normal(normal, outgoing);
  auto reflectivity = gltfpbr_reflectivity(color, ior, metallic);
  auto F            = mean(fresnel_schlick(reflectivity, up, outgoing));
  return F * sample_microfacet_reflection_pdf(
                 roughness, up, outgoing, incoming) +
         (1 - F) * sample_hemisphere_cos_pdf(up, incoming);
}

// -----------------------------------------------------------------------------
// PASSTHROUGH (the boundary of a volumetric material)
// -----------------------------------------------------------------------------

// Everything crosses the surface unchanged.
inline vec3f eval_passthrough(vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) return {0, 0, 0};
  return {1, 1, 1};
}

// Straight through.
inline vec3f sample_passthrough(vec3f outgoing) { return -outgoing; }

// Probability of going straight through.
inline float sample_passthrough_pdf(
    vec3f normal, vec3f outgoing, vec3f incoming) {
  if (dot(normal, incoming) * dot(normal, outgoing) >= 0) return 0;
  return 1;
}

// -----------------------------------------------------------------------------
// MATERIAL DISPATCH
// -----------------------------------------------------------------------------

// Emission, seen only from the side the normal points to.
inline vec3f eval_emission(
    const material_point& material, vec3f normal, vec3f outgoing) {
  return dot(normal, outgoing) >= 0 ? material.emission : vec3f{0, 0, 0};
}

// BSDF * |cos| of a non-delta material; 0 for delta materials.
inline vec3f eval_bsdfcos(const material_point& material, vec3f normal,
    vec3f outgoing, vec3f incoming) {
  if (material.roughness == 0) return {0, 0, 0};
  auto& m = material;
  switch (m.type) {
    case material_type::matte:
      return eval_matte(m.color, normal, outgoing, incoming);
    case material_type::glossy:
      return eval_glossy(
          m.color, m.ior, m.roughness, normal, outgoing, incoming);
    case material_type::reflective:
      return eval_reflective(m.color, m.roughness, normal, outgoing, incoming);
    case material_type::transparent:
      return eval_transparent(
          m.color, m.ior, m.roughness, normal, outgoing, incoming);
    case material_type::refractive:
    case material_type::subsurface:
      return eval_refractive(m.ior, m.roughness, normal, outgoing, incoming);
    case material_type::gltfpbr:
      return eval_gltfpbr(
          m.color, m.ior, m.roughness, m.metallic, normal, outgoing, incoming);
    case material_type::volumetric: return {0, 0, 0};
  }
  return {0, 0, 0};
}

// Direction sampled from a non-delta material; zero when rejected.
inline vec3f sample_bsdfcos(const material_point& material, vec3f normal,
    vec3f outgoing, float rnl, vec2f rn) {
  if (material.roughness == 0) return {0, 0, 0};
  auto& m = material;
  switch (m.type) {
    case material_type::matte: return sample_matte(normal, outgoing, rn);
    case material_type::glossy:
      return sample_glossy(m.ior, m.roughness, normal, outgoing, rnl, rn);
    case material_type::reflective:
      return sample_reflective(m.roughness, normal, outgoing, rn);
    case material_type::transparent:
      return sample_transparent(m.ior, m.roughness, normal, outgoing, rnl, rn);
    case material_type::refractive:
    case material_type::subsurface:
      return sample_refractive(m.ior, m.roughness, normal, outgoing, rnl, rn);
    case material_type::gltfpbr:
      return sample_gltfpbr(
          m.color, m.ior, m.roughness, m.metallic, normal, outgoing, rnl, rn);
    case material_type::volumetric: return {0, 0, 0};
  }
  return {0, 0, 0};
}

// Solid-angle pdf of sample_bsdfcos.
inline float sample_bsdfcos_pdf(const material_point& material, vec3f normal,
    vec3f outgoing, vec3f incoming) {
  if (material.roughness == 0) return 0;
  auto& m = material;
  switch (m.type) {
    case material_type::matte:
      return sample_matte_pdf(normal, outgoing, incoming);
    case material_type::glossy:
      return sample_glossy_pdf(m.ior, m.roughness, normal, outgoing, incoming);
    case material_type::reflective:
      return sample_reflective_pdf(m.roughness, normal, outgoing, incoming);
    case material_type::transparent:
      return sample_transparent_pdf(
          m.ior, m.roughness, normal, outgoing, incoming);
    case material_type::refractive:
    case material_type::subsurface:
      return sample_refractive_pdf(
          m.ior, m.roughness, normal, outgoing, incoming);
    case material_type::gltfpbr:
      return sample_gltfpbr_pdf(
          m.color, m.ior, m.roughness, m.metallic, normal, outgoing, incoming);
    case material_type::volumetric: return 0;
  }
  return 0;
}

// BSDF * |cos| of a delta material, for a direction from sample_delta.
inline vec3f eval_delta(const material_point& material, vec3f normal,
    vec3f outgoing, vec3f incoming) {
  if (material.roughness != 0) return {0, 0, 0};
  auto& m = material;
  switch (m.type) {
    case material_type::matte:
    case material_type::glossy:
    case material_type::gltfpbr: return {0, 0, 0};
    case material_type::reflective:
      return eval_reflective_delta(m.color, normal, outgoing, incoming);
    case material_type::transparent:
      return eval_transparent_delta(m.color, m.ior, normal, outgoing, incoming);
    case material_type::refractive:
    case material_type::subsurface:
      return eval_refractive_delta(m.ior, normal, outgoing, incoming);
    case material_type::volumetric:
      return eval_passthrough(normal, outgoing, incoming);
  }
  return {0, 0, 0};
}

// Direction chosen by a delta material.
inline vec3f sample_delta(
    const material_point& material, vec3f normal, vec3f outgoing, float rnl) {
  if (material.roughness != 0) return {0, 0, 0};
  auto& m = material;
  switch (m.type) {
    case material_type::matte:
    case material_type::glossy:
    case material_type::gltfpbr: return {0, 0, 0};
    case material_type::reflective:
      return sample_reflective_delta(normal, outgoing);
    case material_type::transparent:
      return sample_transparent_delta(m.ior, normal, outgoing, rnl);
    case material_type::refractive:
    case material_type::subsurface:
      return sample_refractive_delta(m.ior, normal, outgoing, rnl);
    case material_type::volumetric: return sample_passthrough(outgoing);
  }
  return {0, 0, 0};
}

// Probability that sample_delta chooses `incoming`.
inline float sample_delta_pdf(const material_point& material, vec3f normal,
    vec3f outgoing, vec3f incoming) {
  if (material.roughness != 0) return 0;
  auto& m = material;
  switch (m.type) {
    case material_type::matte:
    case material_type::glossy:
    case material_type::gltfpbr: return 0;
    case material_type::reflective:
      return sample_reflective_delta_pdf(normal, outgoing, incoming);
    case material_type::transparent:
      return sample_transparent_delta_pdf(m.ior, normal, outgoing, incoming);
    case material_type::refractive:
    case material_type::subsurface:
      return sample_refractive_delta_pdf(m.ior, normal, outgoing, incoming);
    case material_type::volumetric:
      return sample_passthrough_pdf(normal, outgoing, incoming);
  }
  return 0;
}

// -----------------------------------------------------------------------------
// VOLUMES (homogeneous media inside refractive, subsurface and volumetric
// objects)
// -----------------------------------------------------------------------------

// Beer-Lambert transmittance over a distance.
inline vec3f eval_transmittance(vec3f density, float distance) {
  return exp(-density * distance);
}

// Free-flight distance: exponential in one RGB channel picked uniformly by
// `rl`, clamped to `max_distance` (the surface); a channel with zero density
// always reaches the surface.
inline float sample_transmittance(
    vec3f density, float max_distance, float rl, float rd) {
  auto channel  = clamp((int)(rl * 3), 0, 2);
  auto sigma    = at(density, channel);
  auto distance = sigma == 0 ? flt_max : -std::log(1 - rd) / sigma;
  return std::min(distance, max_distance);
}

// Pdf of sample_transmittance: a density before `max_distance`, the
// probability of reaching the surface at it.
inline float sample_transmittance_pdf(
    vec3f density, float distance, float max_distance) {
  if (distance < max_distance) {
    return sum(density * exp(-density * distance)) / 3;
  } else {
    return sum(exp(-density * max_distance)) / 3;
  }
}

// Henyey-Greenstein phase function; positive anisotropy scatters forward,
// i.e. `incoming` close to -outgoing.
inline float eval_phasefunction(
    float anisotropy, vec3f outgoing, vec3f incoming) {
  auto g      = anisotropy;
  auto cosine = -dot(outgoing, incoming);
  auto denom  = 1 + g * g - 2 * g * cosine;
  return (1 - g * g) / (4 * pif * denom * std::sqrt(denom));
}

// Direction distributed as the Henyey-Greenstein phase function.
inline vec3f sample_phasefunction(float anisotropy, vec3f outgoing, vec2f rn) {
  auto g         = anisotropy;
  auto cos_theta = 0.0f;
  if (std::abs(g) < 1e-3f) {
    cos_theta = 1 - 2 * rn.y;
  } else {
    auto square = (1 - g * g) / (1 + g - 2 * g * rn.y);
    cos_theta   = (1 + g * g - square * square) / (2 * g);
  }
  auto sin_theta = std::sqrt(std::max(0.0f, 1 - cos_theta * cos_theta));
  auto phi       = 2 * pif * rn.x;
  auto local =
      vec3f{sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
  return transform_direction(basis_fromz(-outgoing), local);
}

// Pdf of sample_phasefunction.
inline float sample_phasefunction_pdf(
    float anisotropy, vec3f outgoing, vec3f incoming) {
  return eval_phasefunction(anisotropy, outgoing, incoming);
}

// Scattering coefficient times phase function inside a medium.
inline vec3f eval_scattering(
    const material_point& material, vec3f outgoing, vec3f incoming) {
  if (material.density == vec3f{0, 0, 0}) return {0, 0, 0};
  return material.scattering * material.density *
         eval_phasefunction(material.scanisotropy, outgoing, incoming);
}

// Direction scattered inside a medium (`rnl` is unused, kept for symmetry
// with sample_bsdfcos).
inline vec3f sample_scattering(
    const material_point& material, vec3f outgoing, float rnl, vec2f rn) {
  (void)rnl;
  if (material.density == vec3f{0, 0, 0}) return {0, 0, 0};
  return sample_phasefunction(material.scanisotropy, outgoing, rn);
}

// Pdf of sample_scattering.
inline float sample_scattering_pdf(
    const material_point& material, vec3f outgoing, vec3f incoming) {
  if (material.density == vec3f{0, 0, 0}) return 0;
  return sample_phasefunction_pdf(material.scanisotropy, outgoing, incoming);
}

}  // namespace implicit
