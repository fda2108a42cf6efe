// Tests for the material lobes: sampling against pdfs (chi-square, as in
// pbrt-v4's bsdfs_test.cpp), energy, reciprocity, delta lobes, volumes, and
// fuzzing for NaNs. All random streams have fixed seeds.
#include "shading.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "../math/random.h"

using namespace implicit;

namespace {

// -----------------------------------------------------------------------------
// STATISTICS
// -----------------------------------------------------------------------------

constexpr double pi_d = 3.14159265358979323846;

// Regularized upper incomplete gamma function Q(a, x) (series for small x,
// Lentz's continued fraction otherwise; Numerical Recipes, 6.2).
double gamma_q(double a, double x) {
  if (x <= 0) return 1;
  auto prefix = std::exp(-x + a * std::log(x) - std::lgamma(a));
  if (x < a + 1) {
    auto sum = 1 / a, term = sum;
    for (auto n = 1; n < 10000; n++) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return 1 - sum * prefix;
  }
  auto tiny = 1e-300;
  auto b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (auto i = 1; i < 10000; i++) {
    auto an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d        = 1 / d;
    auto del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-16) break;
  }
  return prefix * h;
}

// Chi-square test of observed against expected counts, pooling the cells
// with expected count < 5 (pbrt-v4 Chi2Test). Samples in cells with expected
// count 0 are reported separately: they mean the pdf misses part of the
// sampled distribution.
struct chi2_result {
  double chi2       = 0;
  int    dof        = 0;
  double pvalue     = 0;
  double unexpected = 0;
};
chi2_result chi2_test(
    const std::vector<double>& observed, const std::vector<double>& expected) {
  auto order = std::vector<size_t>(observed.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
      [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  auto result     = chi2_result{};
  auto pooled_obs = 0.0, pooled_exp = 0.0;
  for (auto idx : order) {
    if (expected[idx] <= 0) {
      result.unexpected += observed[idx];
    } else if (expected[idx] < 5 || (pooled_exp > 0 && pooled_exp < 5)) {
      pooled_obs += observed[idx];
      pooled_exp += expected[idx];
    } else {
      auto diff = observed[idx] - expected[idx];
      result.chi2 += diff * diff / expected[idx];
      result.dof += 1;
    }
  }
  if (pooled_exp > 0) {
    auto diff = pooled_obs - pooled_exp;
    result.chi2 += diff * diff / pooled_exp;
    result.dof += 1;
  }
  result.dof -= 1;
  result.pvalue =
      result.dof > 0 ? gamma_q(result.dof / 2.0, result.chi2 / 2) : 1.0;
  return result;
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n).
struct quadrature {
  std::vector<double> nodes, weights;
};
quadrature gauss_legendre(int n) {
  auto q = quadrature{std::vector<double>(n), std::vector<double>(n)};
  for (auto i = 0; i < n; i++) {
    auto x = std::cos(pi_d * (i + 0.75) / (n + 0.5)), dp = 0.0;
    for (auto iter = 0; iter < 100; iter++) {
      auto p0 = 1.0, p1 = x;
      for (auto k = 2; k <= n; k++) {
        auto p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
        p0      = p1;
        p1      = p2;
      }
      dp      = n * (x * p1 - p0) / (x * x - 1);
      auto dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-15) break;
    }
    q.nodes[i]   = x;
    q.weights[i] = 2 / ((1 - x * x) * dp * dp);
  }
  return q;
}

// -----------------------------------------------------------------------------
// DIRECTION HISTOGRAMS
// -----------------------------------------------------------------------------

// Histogram resolution (theta_res even: the horizon is a bin edge, where the
// pdfs jump), quadrature per bin and sample counts. Unoptimized sanitizer
// builds run ~10x slower, so they take fewer samples and a coarser (still
// accurate enough for those counts) quadrature; the wrong-pdf controls still
// fail by far.
constexpr int theta_res = 40, phi_res = 80;
#ifdef NDEBUG
constexpr int sub_cells = 2, gl_order = 6;
constexpr int chi2_samples = 200000, albedo_samples = 40000;
#else
constexpr int sub_cells = 1, gl_order = 5;
constexpr int chi2_samples = 50000, albedo_samples = 10000;
#endif

// A sampler against its pdf over the sphere, binned in theta/phi around
// `axis`. The last cell counts rejected samples (zero directions) and
// expects samples * (1 - integral of the pdf).
struct direction_test {
  chi2_result chi2           = {};
  double      pdf_integral   = 0;
  double      valid_fraction = 0;
};
template <typename Sample, typename Pdf>
direction_test test_directions(
    vec3f axis, int samples, uint64_t seed, Sample&& sample, Pdf&& pdf) {
  auto frame    = basis_fromz(axis);
  auto cells    = theta_res * phi_res;
  auto observed = std::vector<double>(cells + 1, 0.0);
  auto expected = std::vector<double>(cells + 1, 0.0);

  auto rng = make_rng(seed);
  for (auto s = 0; s < samples; s++) {
    auto direction = sample(rng);
    if (direction == vec3f{0, 0, 0}) {
      observed[cells] += 1;
      continue;
    }
    auto local = vec3f{dot(direction, frame.x), dot(direction, frame.y),
        dot(direction, frame.z)};
    auto theta = std::acos(std::clamp((double)local.z, -1.0, 1.0));
    auto phi   = std::atan2((double)local.y, (double)local.x);
    if (phi < 0) phi += 2 * pi_d;
    auto ti = std::clamp((int)(theta / pi_d * theta_res), 0, theta_res - 1);
    auto pj = std::clamp((int)(phi / (2 * pi_d) * phi_res), 0, phi_res - 1);
    observed[ti * phi_res + pj] += 1;
  }

  // Integrate the pdf over each bin: sub_cells^2 Gauss-Legendre patches,
  // with the sin(theta) of the solid angle.
  auto gl     = gauss_legendre(gl_order);
  auto dtheta = pi_d / theta_res / sub_cells;
  auto dphi   = 2 * pi_d / phi_res / sub_cells;
  auto total  = 0.0;
  for (auto ti = 0; ti < theta_res; ti++) {
    for (auto pj = 0; pj < phi_res; pj++) {
      auto integral = 0.0;
      for (auto st = 0; st < sub_cells; st++) {
        for (auto sp = 0; sp < sub_cells; sp++) {
          auto theta0 = (ti * sub_cells + st) * dtheta;
          auto phi0   = (pj * sub_cells + sp) * dphi;
          for (auto a = 0; a < gl_order; a++) {
            auto theta = theta0 + (gl.nodes[a] + 1) / 2 * dtheta;
            for (auto b = 0; b < gl_order; b++) {
              auto phi       = phi0 + (gl.nodes[b] + 1) / 2 * dphi;
              auto local     = vec3f{(float)(std::sin(theta) * std::cos(phi)),
                  (float)(std::sin(theta) * std::sin(phi)),
                  (float)std::cos(theta)};
              auto direction = transform_direction(frame, local);
              integral += gl.weights[a] * gl.weights[b] / 4 * dtheta * dphi *
                          std::sin(theta) * (double)pdf(direction);
            }
          }
        }
      }
      expected[ti * phi_res + pj] = integral * samples;
      total += integral;
    }
  }
  expected[cells] = std::max(0.0, 1 - total) * samples;

  auto result           = direction_test{};
  result.chi2           = chi2_test(observed, expected);
  result.pdf_integral   = total;
  result.valid_fraction = 1 - observed[cells] / samples;
  return result;
}

// -----------------------------------------------------------------------------
// HELPERS
// -----------------------------------------------------------------------------

// A tilted normal, so that the tests go through basis_fromz.
const vec3f test_normal = normalize(vec3f{0.3f, -0.2f, 0.9f});

// Direction at angle `degrees` from `normal` (beyond 90: below the surface),
// in a fixed plane containing it.
vec3f direction_at(vec3f normal, float degrees, float azimuth = 0.4f) {
  auto frame = basis_fromz(normal);
  auto theta = radians(degrees);
  auto local = vec3f{std::sin(theta) * std::cos(azimuth),
      std::sin(theta) * std::sin(azimuth), std::cos(theta)};
  return transform_direction(frame, local);
}

// Material point of a material type, via make_material_point.
material_point make_test_material(material_type type, vec3f color,
    float roughness, float ior = 1.5f, float metallic = 0) {
  auto material      = material_data{};
  material.type      = type;
  material.color     = color;
  material.roughness = roughness;
  material.ior       = ior;
  material.metallic  = metallic;
  return make_material_point(material);
}

// Smallest accepted p-value (per test; seeds are fixed).
constexpr double min_pvalue = 1e-4;

// Chi-square test of sample_bsdfcos against sample_bsdfcos_pdf, plus the pdf
// integral against the fraction of accepted samples.
direction_test check_bsdf_sampling(
    const material_point& material, vec3f outgoing, uint64_t seed) {
  auto normal = test_normal;
  // a different stream for each outgoing direction
  seed        = seed * 10007 + (uint64_t)(1000 * (2 + dot(normal, outgoing)));
  auto result = test_directions(
      normal, chi2_samples, seed,
      [&](rng_state& rng) {
        auto rnl = rand1f(rng);
        auto rn  = rand2f(rng);
        return sample_bsdfcos(material, normal, outgoing, rnl, rn);
      },
      [&](vec3f incoming) {
        return sample_bsdfcos_pdf(material, normal, outgoing, incoming);
      });
  INFO("chi2 = ", result.chi2.chi2, " dof = ", result.chi2.dof,
      " p = ", result.chi2.pvalue, " integral = ", result.pdf_integral,
      " valid = ", result.valid_fraction);
  CHECK(result.chi2.pvalue > min_pvalue);
  CHECK(result.chi2.unexpected == 0);
  CHECK(result.pdf_integral <= 1 + 1e-3);
  // The accepted fraction estimates the pdf integral: 5 binomial standard
  // errors, plus the quadrature error.
  auto p = result.valid_fraction;
  CHECK(std::abs(result.pdf_integral - p) <
        5 * std::sqrt(p * (1 - p) / chi2_samples) + 1e-3);
  return result;
}

// Monte Carlo albedo E[eval / pdf] over sampled directions, with its
// standard error; `transmission_scale` multiplies samples that cross the
// surface (to undo the 1/eta^2 radiance scaling of refraction).
struct albedo_estimate {
  vec3f mean  = {0, 0, 0};
  float error = 0;
};
albedo_estimate estimate_albedo(const material_point& material, vec3f normal,
    vec3f outgoing, int samples, uint64_t seed, float transmission_scale = 1) {
  auto rng  = make_rng(seed);
  auto sum  = std::vector<double>(3, 0.0);
  auto sum2 = 0.0;
  for (auto s = 0; s < samples; s++) {
    auto incoming =
        sample_bsdfcos(material, normal, outgoing, rand1f(rng), rand2f(rng));
    if (incoming == vec3f{0, 0, 0}) continue;
    auto pdf = sample_bsdfcos_pdf(material, normal, outgoing, incoming);
    if (pdf <= 0) continue;
    auto weight = eval_bsdfcos(material, normal, outgoing, incoming) / pdf;
    if (!same_hemisphere(normal, outgoing, incoming))
      weight *= transmission_scale;
    for (auto c = 0; c < 3; c++) sum[c] += at(weight, c);
    sum2 += (double)max(weight) * max(weight);
  }
  auto mean     = vec3f{(float)(sum[0] / samples), (float)(sum[1] / samples),
      (float)(sum[2] / samples)};
  auto variance = sum2 / samples - (double)max(mean) * max(mean);
  return {mean, (float)std::sqrt(std::max(0.0, variance) / samples)};
}

}  // namespace

// -----------------------------------------------------------------------------
// MATERIAL POINT
// -----------------------------------------------------------------------------

TEST_CASE("shading: make_material_point squares and clamps roughness") {
  auto material      = material_data{};
  material.roughness = 0.5f;
  for (auto type :
      {material_type::matte, material_type::glossy, material_type::reflective,
          material_type::transparent, material_type::refractive,
          material_type::subsurface, material_type::gltfpbr}) {
    material.type = type;
    CHECK(make_material_point(material).roughness == doctest::Approx(0.25f));
  }
  material.type = material_type::volumetric;
  CHECK(make_material_point(material).roughness == 0);

  // Too smooth: diffuse-based lobes clamp to 0.03^2, the others go delta.
  material.roughness = 0.02f;
  for (auto type :
      {material_type::matte, material_type::glossy, material_type::gltfpbr}) {
    material.type = type;
    CHECK(make_material_point(material).roughness == min_roughness);
  }
  for (auto type : {material_type::reflective, material_type::transparent,
           material_type::refractive, material_type::subsurface}) {
    material.type = type;
    CHECK(make_material_point(material).roughness == 0);
  }
  material.roughness = 0.031f;
  material.type      = material_type::reflective;
  CHECK(make_material_point(material).roughness ==
        doctest::Approx(0.031f * 0.031f));
  material.roughness = 2;
  material.type      = material_type::glossy;
  CHECK(make_material_point(material).roughness == 1);

  // An interface with index 1 is the delta pass-through, however rough.
  material.roughness = 0.5f;
  material.ior       = 1;
  for (auto type : {material_type::refractive, material_type::subsurface}) {
    material.type = type;
    auto point    = make_material_point(material);
    CHECK(point.roughness == 0);
    CHECK(is_delta(point));
    auto normal = vec3f{0, 0, 1}, outgoing = vec3f{0.6f, 0, 0.8f};
    CHECK(sample_delta(point, normal, outgoing, 0.0f) == -outgoing);
    CHECK(eval_delta(point, normal, outgoing, -outgoing) == vec3f{1, 1, 1});
  }
  material.type = material_type::transparent;  // a thin sheet still scatters
  CHECK(make_material_point(material).roughness == doctest::Approx(0.25f));
}

TEST_CASE("shading: make_material_point applies texels and density") {
  auto material         = material_data{};
  material.type         = material_type::refractive;
  material.color        = {0.5f, 1.0f, 0.0f};
  material.emission     = {2, 3, 4};
  material.roughness    = 0.8f;
  material.metallic     = 0.5f;
  material.opacity      = 0.8f;
  material.trdepth      = 0.1f;
  material.ior          = 1.33f;
  material.scattering   = {0.2f, 0.4f, 0.6f};
  material.scanisotropy = 0.3f;

  auto point = make_material_point(material, {0.5f, 1, 1, 0.5f},
      {0.5f, 0.25f, 1, 1}, {1, 0.5f, 0.4f, 1}, {1, 0.5f, 0.25f, 1});
  CHECK(point.type == material_type::refractive);
  CHECK(point.color.x == doctest::Approx(0.25f));
  CHECK(point.color.y == doctest::Approx(1.0f));
  CHECK(point.color.z == 0);
  CHECK(point.opacity == doctest::Approx(0.4f));
  CHECK(point.emission.x == doctest::Approx(1.0f));
  CHECK(point.emission.y == doctest::Approx(0.75f));
  CHECK(point.emission.z == doctest::Approx(4.0f));
  CHECK(point.roughness == doctest::Approx(0.16f));  // (0.8 * 0.5)^2
  CHECK(point.metallic == doctest::Approx(0.2f));
  CHECK(point.scattering.y == doctest::Approx(0.2f));
  CHECK(point.scattering.z == doctest::Approx(0.15f));
  CHECK(point.ior == 1.33f);
  CHECK(point.scanisotropy == 0.3f);
  CHECK(point.trdepth == 0.1f);
  // density = -ln(color) / trdepth, color clamped to [1e-4, 1]
  CHECK(point.density.x == doctest::Approx(-std::log(0.25f) / 0.1f));
  CHECK(point.density.y == 0);
  CHECK(point.density.z == doctest::Approx(-std::log(1e-4f) / 0.1f));
  // the transmittance over trdepth is the color
  CHECK(eval_transmittance(point.density, 0.1f).x == doctest::Approx(0.25f));

  for (auto type : {material_type::volumetric, material_type::subsurface}) {
    material.type = type;
    CHECK(make_material_point(material).density.x ==
          doctest::Approx(-std::log(0.5f) / 0.1f));
  }
  for (auto type :
      {material_type::matte, material_type::glossy, material_type::reflective,
          material_type::transparent, material_type::gltfpbr}) {
    material.type = type;
    CHECK(make_material_point(material).density == vec3f{0, 0, 0});
  }
}

TEST_CASE("shading: delta, volumetric and emission predicates") {
  auto rough = [](material_type type) {
    return make_test_material(type, {1, 1, 1}, 0.5f);
  };
  auto smooth = [](material_type type) {
    return make_test_material(type, {1, 1, 1}, 0);
  };
  CHECK(!is_delta(smooth(material_type::matte)));
  CHECK(!is_delta(smooth(material_type::glossy)));
  CHECK(!is_delta(smooth(material_type::gltfpbr)));
  CHECK(is_delta(smooth(material_type::reflective)));
  CHECK(is_delta(smooth(material_type::transparent)));
  CHECK(is_delta(smooth(material_type::refractive)));
  CHECK(is_delta(smooth(material_type::subsurface)));
  CHECK(is_delta(rough(material_type::volumetric)));
  CHECK(!is_delta(rough(material_type::reflective)));
  CHECK(!is_delta(rough(material_type::refractive)));
  CHECK(is_volumetric(rough(material_type::refractive)));
  CHECK(is_volumetric(rough(material_type::subsurface)));
  CHECK(is_volumetric(rough(material_type::volumetric)));
  CHECK(!is_volumetric(rough(material_type::transparent)));
  CHECK(!is_volumetric(rough(material_type::matte)));

  auto emissive     = rough(material_type::matte);
  emissive.emission = {1, 2, 3};
  auto normal       = vec3f{0, 0, 1};
  CHECK(eval_emission(emissive, normal, {0, 0.6f, 0.8f}) == vec3f{1, 2, 3});
  CHECK(eval_emission(emissive, normal, {0, 0.6f, -0.8f}) == vec3f{0, 0, 0});

  // Delta and non-delta entry points ignore the other kind.
  auto outgoing = vec3f{0, 0.6f, 0.8f};
  auto incoming = vec3f{0, -0.6f, 0.8f};
  auto mirror   = smooth(material_type::reflective);
  CHECK(sample_bsdfcos(mirror, normal, outgoing, 0.5f, {0.5f, 0.5f}) ==
        vec3f{0, 0, 0});
  CHECK(eval_bsdfcos(mirror, normal, outgoing, incoming) == vec3f{0, 0, 0});
  CHECK(sample_bsdfcos_pdf(mirror, normal, outgoing, incoming) == 0);
  auto matte = rough(material_type::matte);
  CHECK(sample_delta(matte, normal, outgoing, 0.5f) == vec3f{0, 0, 0});
  CHECK(eval_delta(matte, normal, outgoing, incoming) == vec3f{0, 0, 0});
  CHECK(sample_delta_pdf(matte, normal, outgoing, incoming) == 0);
}

// -----------------------------------------------------------------------------
// FRESNEL AND MICROFACETS
// -----------------------------------------------------------------------------

TEST_CASE("shading: fresnel terms") {
  auto normal = vec3f{0, 0, 1};
  for (auto eta : {1.33f, 1.5f, 2.4f}) {
    auto expected = ((eta - 1) / (eta + 1)) * ((eta - 1) / (eta + 1));
    CHECK(fresnel_dielectric(eta, normal, normal) == doctest::Approx(expected));
    // from the denser side, at normal incidence, the same
    CHECK(fresnel_dielectric(1 / eta, normal, normal) ==
          doctest::Approx(expected));
    CHECK(eta_to_reflectivity({eta, eta, eta}).x == doctest::Approx(expected));
    CHECK(reflectivity_to_eta({expected, expected, expected}).y ==
          doctest::Approx(eta));
    // a conductor with no absorption is a dielectric, at every angle
    for (auto degrees : {0.0f, 30.0f, 60.0f, 85.0f}) {
      auto w = direction_at(normal, degrees);
      CHECK(fresnel_conductor({eta, eta, eta}, {0, 0, 0}, normal, w).x ==
            doctest::Approx(fresnel_dielectric(eta, normal, w)).epsilon(1e-4));
    }
  }
  // Brewster's angle: the p-polarized reflectance vanishes, so F = rs^2 / 2.
  auto brewster = direction_at(normal, std::atan(1.5f) * 180 / pif);
  auto cos_i = std::cos(std::atan(1.5f)), cos_t = std::sin(std::atan(1.5f));
  auto rs = (cos_i - 1.5f * cos_t) / (cos_i + 1.5f * cos_t);
  CHECK(fresnel_dielectric(1.5f, normal, brewster) ==
        doctest::Approx(rs * rs / 2).epsilon(1e-4));
  // total internal reflection beyond the critical angle asin(1/1.5)
  CHECK(fresnel_dielectric(1 / 1.5f, normal, direction_at(normal, 41)) < 1);
  CHECK(fresnel_dielectric(1 / 1.5f, normal, direction_at(normal, 43)) == 1);
  // grazing: 1, also for eta = 1 where the formula is 0/0
  CHECK(fresnel_dielectric(1.5f, normal, {1, 0, 0}) == 1);
  CHECK(fresnel_dielectric(1, normal, {1, 0, 0}) == 1);
  CHECK(fresnel_dielectric(1, normal, direction_at(normal, 45)) == 0);
  // conductors reflect nothing from below
  CHECK(fresnel_conductor({2, 2, 2}, {3, 3, 3}, normal, -normal) ==
        vec3f{0, 0, 0});
  // Schlick: the reflectivity at normal incidence, 1 at grazing
  auto s = vec3f{0.04f, 0.5f, 0.9f};
  CHECK(fresnel_schlick(s, normal, normal).y == doctest::Approx(0.5f));
  CHECK(fresnel_schlick(s, normal, {1, 0, 0}).x == doctest::Approx(1.0f));
  CHECK(fresnel_schlick({0, 0, 0}, normal, {1, 0, 0}) == vec3f{0, 0, 0});
  // reflectivity clamped to 0.99 keeps eta finite
  CHECK(std::isfinite(reflectivity_to_eta({1, 1, 1}).x));
}

TEST_CASE("shading: microfacet distribution is normalized and sampled") {
  auto normal = test_normal;
  for (auto roughness : {0.04f, 0.25f, 0.49f, 1.0f}) {
    INFO("roughness = ", roughness);
    // D(h) cos(n, h) integrates to 1 over the hemisphere, and
    // sample_microfacet draws exactly that.
    auto result = test_directions(
        normal, chi2_samples, 7,
        [&](rng_state& rng) {
          return sample_microfacet(roughness, normal, rand2f(rng));
        },
        [&](vec3f halfway) {
          return sample_microfacet_pdf(roughness, normal, halfway);
        });
    CHECK(result.pdf_integral == doctest::Approx(1.0).epsilon(2e-3));
    CHECK(result.chi2.pvalue > min_pvalue);
    // Smith G1 is 1 at normal incidence and in [0, 1]
    CHECK(microfacet_shadowing1(roughness, normal, normal, normal) ==
          doctest::Approx(1.0f));
    auto g1 = microfacet_shadowing1(
        roughness, normal, normal, direction_at(normal, 80));
    CHECK(g1 > 0);
    CHECK(g1 < 1);
  }
}

// -----------------------------------------------------------------------------
// SAMPLING AGAINST PDFS
// -----------------------------------------------------------------------------

TEST_CASE("shading: matte sampling matches pdf") {
  auto matte = make_test_material(material_type::matte, {0.8f, 0.5f, 0.2f}, 0);
  for (auto degrees : {10.0f, 70.0f, 130.0f}) {
    INFO("outgoing angle = ", degrees);
    auto result =
        check_bsdf_sampling(matte, direction_at(test_normal, degrees), 11);
    CHECK(result.pdf_integral == doctest::Approx(1.0).epsilon(1e-3));
    CHECK(result.valid_fraction == 1);
  }
}

TEST_CASE("shading: glossy sampling matches pdf") {
  for (auto roughness : {0.2f, 0.7f}) {
    auto glossy = make_test_material(
        material_type::glossy, {0.8f, 0.5f, 0.2f}, roughness);
    for (auto degrees : {30.0f, 75.0f, 120.0f}) {
      INFO("roughness = ", roughness, " outgoing angle = ", degrees);
      check_bsdf_sampling(glossy, direction_at(test_normal, degrees), 12);
    }
  }
}

TEST_CASE("shading: reflective sampling matches pdf") {
  for (auto roughness : {0.2f, 0.5f}) {
    auto metal = make_test_material(
        material_type::reflective, {0.9f, 0.6f, 0.3f}, roughness);
    for (auto degrees : {20.0f, 70.0f, 160.0f}) {
      INFO("roughness = ", roughness, " outgoing angle = ", degrees);
      auto result =
          check_bsdf_sampling(metal, direction_at(test_normal, degrees), 13);
      // reflection only: near normal incidence, little of the lobe goes
      // below the surface
      if (degrees == 20.0f) CHECK(result.pdf_integral > 0.93);
      if (degrees == 20.0f && roughness == 0.2f)
        CHECK(result.pdf_integral > 0.995);
    }
  }
}

TEST_CASE("shading: transparent sampling matches pdf") {
  for (auto roughness : {0.3f, 0.6f}) {
    auto sheet = make_test_material(
        material_type::transparent, {0.7f, 0.8f, 0.9f}, roughness);
    for (auto degrees : {30.0f, 70.0f, 140.0f}) {
      INFO("roughness = ", roughness, " outgoing angle = ", degrees);
      check_bsdf_sampling(sheet, direction_at(test_normal, degrees), 14);
    }
  }
}

TEST_CASE("shading: refractive sampling matches pdf from both sides") {
  for (auto roughness : {0.3f, 0.6f}) {
    auto glass = make_test_material(
        material_type::refractive, {1, 1, 1}, roughness, 1.5f);
    // outside, then inside below and beyond the critical angle (41.8 deg)
    for (auto degrees : {30.0f, 70.0f, 160.0f, 120.0f}) {
      INFO("roughness = ", roughness, " outgoing angle = ", degrees);
      check_bsdf_sampling(glass, direction_at(test_normal, degrees), 15);
    }
  }
  // subsurface shares the lobe
  auto skin =
      make_test_material(material_type::subsurface, {1, 1, 1}, 0.4f, 1.4f);
  check_bsdf_sampling(skin, direction_at(test_normal, 50), 16);
}

TEST_CASE("shading: gltfpbr sampling matches pdf") {
  for (auto metallic : {0.0f, 1.0f}) {
    auto pbr = make_test_material(
        material_type::gltfpbr, {0.8f, 0.5f, 0.2f}, 0.4f, 1.5f, metallic);
    for (auto degrees : {30.0f, 80.0f, 110.0f}) {
      INFO("metallic = ", metallic, " outgoing angle = ", degrees);
      check_bsdf_sampling(pbr, direction_at(test_normal, degrees), 17);
    }
  }
}

TEST_CASE("shading: chi-square test rejects wrong pdfs") {
  auto normal   = test_normal;
  auto outgoing = direction_at(normal, 30);

  // Cosine-weighted samples against a uniform-hemisphere pdf.
  auto matte  = make_test_material(material_type::matte, {1, 1, 1}, 0);
  auto result = test_directions(
      normal, chi2_samples, 21,
      [&](rng_state& rng) {
        return sample_bsdfcos(matte, normal, outgoing, 0.5f, rand2f(rng));
      },
      [&](vec3f incoming) {
        return dot(normal, incoming) > 0 ? 1 / (2 * pif) : 0.0f;
      });
  CHECK(result.chi2.pvalue < 1e-10);

  // Yocto/GL 4.2's rough refraction pdf, without the rel_ior^2 Jacobian
  // factor, from both sides.
  auto glass = make_test_material(material_type::refractive, {1, 1, 1}, 0.5f);
  for (auto degrees : {30.0f, 150.0f}) {
    auto wo      = direction_at(normal, degrees);
    auto rel_ior = dot(normal, wo) >= 0 ? glass.ior : 1 / glass.ior;
    auto yocto   = test_directions(
          normal, chi2_samples, 22,
          [&](rng_state& rng) {
          auto rnl = rand1f(rng);
          return sample_bsdfcos(glass, normal, wo, rnl, rand2f(rng));
        },
          [&](vec3f incoming) {
          auto pdf = sample_bsdfcos_pdf(glass, normal, wo, incoming);
          return same_hemisphere(normal, wo, incoming)
                       ? pdf
                       : pdf / (rel_ior * rel_ior);
        });
    CHECK(yocto.chi2.pvalue < 1e-10);
  }
}

// -----------------------------------------------------------------------------
// ENERGY AND RECIPROCITY
// -----------------------------------------------------------------------------

TEST_CASE("shading: albedo of white lobes is at most one") {
  auto normal  = test_normal;
  auto white   = vec3f{1, 1, 1};
  auto samples = albedo_samples;
  auto lobes   = std::vector<material_point>{
        make_test_material(material_type::matte, white, 0),
        make_test_material(material_type::glossy, white, 0.2f),
        make_test_material(material_type::glossy, white, 0.7f),
        make_test_material(material_type::reflective, white, 0.2f),
        make_test_material(material_type::reflective, white, 0.7f),
        make_test_material(material_type::transparent, white, 0.3f),
        make_test_material(material_type::transparent, white, 0.8f),
        make_test_material(material_type::refractive, white, 0.3f),
        make_test_material(material_type::refractive, white, 0.8f),
        make_test_material(material_type::gltfpbr, white, 0.3f, 1.5f, 0),
        make_test_material(material_type::gltfpbr, white, 0.8f, 1.5f, 1),
  };
  for (auto& lobe : lobes) {
    for (auto degrees : {0.0f, 30.0f, 60.0f, 85.0f, 140.0f}) {
      INFO("type = ", material_type_names[(int)lobe.type],
          " roughness = ", lobe.roughness, " outgoing angle = ", degrees);
      auto outgoing = direction_at(normal, degrees);
      // Refraction scales radiance by 1/rel_ior^2; undo it to check energy.
      auto rel_ior = dot(normal, outgoing) >= 0 ? lobe.ior : 1 / lobe.ior;
      auto scale =
          lobe.type == material_type::refractive ? rel_ior * rel_ior : 1.0f;
      auto albedo = estimate_albedo(lobe, normal, outgoing, samples, 31, scale);
      INFO("albedo = ", albedo.mean.x, " +- ", albedo.error);
      CHECK(max(albedo.mean) <= 1 + 0.01f + 4 * albedo.error);
      CHECK(min(albedo.mean) > 0.3f);
      // Without the correction, entering glass keeps only 1/ior^2 of the
      // transmitted energy, so the raw albedo is below one there too.
      if (lobe.type == material_type::refractive && rel_ior > 1) {
        auto raw = estimate_albedo(lobe, normal, outgoing, samples, 32);
        CHECK(max(raw.mean) <= 1 + 4 * raw.error);
      }
    }
  }
}

TEST_CASE("shading: matte albedo is its color") {
  auto color = vec3f{0.8f, 0.5f, 0.2f};
  auto matte = make_test_material(material_type::matte, color, 0);
  for (auto degrees : {0.0f, 45.0f, 89.0f, 135.0f}) {
    auto albedo = estimate_albedo(
        matte, test_normal, direction_at(test_normal, degrees), 20000, 33);
    CHECK(albedo.mean.x == doctest::Approx(color.x).epsilon(1e-3));
    CHECK(albedo.mean.y == doctest::Approx(color.y).epsilon(1e-3));
    CHECK(albedo.mean.z == doctest::Approx(color.z).epsilon(1e-3));
  }
}

TEST_CASE("shading: reflection lobes are reciprocal") {
  // Glossy and gltfpbr weight their diffuse base by 1 - F(outgoing), which is
  // not reciprocal (as in Yocto/GL); their specular parts are.
  auto lobes = std::vector<material_point>{
      make_test_material(material_type::matte, {0.8f, 0.5f, 0.2f}, 0),
      make_test_material(material_type::glossy, {0, 0, 0}, 0.3f),
      make_test_material(material_type::glossy, {0, 0, 0}, 0.8f),
      make_test_material(material_type::reflective, {0.9f, 0.6f, 0.3f}, 0.2f),
      make_test_material(material_type::reflective, {0.9f, 0.6f, 0.3f}, 0.7f),
      make_test_material(
          material_type::gltfpbr, {0.9f, 0.6f, 0.3f}, 0.5f, 1.5f, 1),
  };
  auto rng    = make_rng(41);
  auto tested = 0;
  for (auto& lobe : lobes) {
    for (auto trial = 0; trial < 2000; trial++) {
      auto normal   = sample_sphere(rand2f(rng));
      auto outgoing = sample_sphere(rand2f(rng));
      auto incoming = sample_sphere(rand2f(rng));
      auto cos_o    = std::abs(dot(normal, outgoing));
      auto cos_i    = std::abs(dot(normal, incoming));
      if (cos_o < 1e-3f || cos_i < 1e-3f) continue;
      auto forward  = eval_bsdfcos(lobe, normal, outgoing, incoming) / cos_i;
      auto backward = eval_bsdfcos(lobe, normal, incoming, outgoing) / cos_o;
      INFO("type = ", material_type_names[(int)lobe.type]);
      for (auto c = 0; c < 3; c++) {
        CHECK(at(forward, c) ==
              doctest::Approx(at(backward, c)).epsilon(1e-4).scale(1e-6));
      }
      if (max(forward) > 0) tested++;
    }
  }
  CHECK(tested > 3000);  // half the pairs lie on one side
}

// -----------------------------------------------------------------------------
// DELTA LOBES
// -----------------------------------------------------------------------------

TEST_CASE("shading: delta lobes obey the mirror law and Snell's law") {
  auto normal = test_normal;
  // mirror: equal angles, in the plane of incidence, on the same side
  auto mirror = make_test_material(material_type::reflective, {1, 1, 1}, 0);
  for (auto degrees : {0.0f, 30.0f, 80.0f, 150.0f}) {
    INFO("outgoing angle = ", degrees);
    auto outgoing = direction_at(normal, degrees);
    auto incoming = sample_delta(mirror, normal, outgoing, 0.5f);
    CHECK(dot(normal, incoming) == doctest::Approx(dot(normal, outgoing)));
    CHECK(length(cross(incoming + outgoing, normal)) < 1e-5f);
    CHECK(length(incoming) == doctest::Approx(1.0f));
    CHECK(sample_delta_pdf(mirror, normal, outgoing, incoming) == 1);
    // a white conductor (reflectivity clamped to 0.99, so eta = 399) reflects
    // ~all; its Brewster dip near grazing takes a few percent
    auto reflected = eval_delta(mirror, normal, outgoing, incoming);
    CHECK(min(reflected) >= 0.97f);
    CHECK(max(reflected) <= 1);
  }
  auto outgoing = direction_at(normal, 0);
  CHECK(eval_delta(mirror, normal, outgoing, outgoing).x ==
        doctest::Approx(0.99f));

  // glass: Snell's law from both sides, Fresnel-weighted choice
  auto ior   = 1.5f;
  auto glass = make_test_material(material_type::refractive, {1, 1, 1}, 0, ior);
  for (auto degrees : {0.0f, 30.0f, 60.0f, 150.0f, 170.0f}) {
    INFO("outgoing angle = ", degrees);
    auto wo       = direction_at(normal, degrees);
    auto entering = dot(normal, wo) > 0;
    auto rel_ior  = entering ? ior : 1 / ior;
    auto F        = fresnel_dielectric(rel_ior, normal, wo);
    auto wi       = sample_delta(glass, normal, wo, 0.999f);  // refract
    CHECK(dot(normal, wi) * dot(normal, wo) < 0);
    auto sin_o = length(cross(normal, wo)), sin_i = length(cross(normal, wi));
    CHECK(std::abs(sin_o - rel_ior * sin_i) < 1e-5f);
    CHECK(std::abs(dot(cross(normal, wo), wi)) < 1e-5f);  // coplanar
    CHECK(sample_delta_pdf(glass, normal, wo, wi) == doctest::Approx(1 - F));
    CHECK(eval_delta(glass, normal, wo, wi).x ==
          doctest::Approx((1 - F) / (rel_ior * rel_ior)));
    auto wr = sample_delta(glass, normal, wo, 0.0f);  // reflect
    CHECK(dot(normal, wr) == doctest::Approx(dot(normal, wo)));
    CHECK(sample_delta_pdf(glass, normal, wo, wr) == doctest::Approx(F));
    CHECK(eval_delta(glass, normal, wo, wr).x == doctest::Approx(F));
  }
  // at normal incidence F = ((n-1)/(n+1))^2 = 0.04
  CHECK(sample_delta_pdf(glass, normal, normal, -normal) ==
        doctest::Approx(0.96f));
  // total internal reflection beyond asin(1/1.5) = 41.8 degrees
  auto tir_o = direction_at(normal, 180 - 45);
  for (auto rnl : {0.0f, 0.5f, 0.9999f}) {
    auto wi = sample_delta(glass, normal, tir_o, rnl);
    CHECK(dot(normal, wi) == doctest::Approx(dot(normal, tir_o)));
  }
  // an index of 1 is no interface
  auto air = make_test_material(material_type::refractive, {1, 1, 1}, 0, 1);
  CHECK(sample_delta(air, normal, direction_at(normal, 30), 0) ==
        -direction_at(normal, 30));

  // thin sheet: straight through, colored by 1 - F
  auto sheet = make_test_material(
      material_type::transparent, {0.5f, 0.7f, 0.9f}, 0, ior);
  for (auto degrees : {20.0f, 160.0f}) {
    auto wo = direction_at(normal, degrees);
    auto F  = fresnel_dielectric(ior, normal, wo);
    auto wt = sample_delta(sheet, normal, wo, 0.999f);
    CHECK(wt == -wo);
    CHECK(
        eval_delta(sheet, normal, wo, wt).y == doctest::Approx(0.7f * (1 - F)));
    CHECK(sample_delta_pdf(sheet, normal, wo, wt) == doctest::Approx(1 - F));
    auto wr = sample_delta(sheet, normal, wo, 0.0f);
    CHECK(dot(normal, wr) == doctest::Approx(dot(normal, wo)));
    CHECK(eval_delta(sheet, normal, wo, wr).y == doctest::Approx(F));
  }

  // volumetric boundary: pass-through
  auto fog =
      make_test_material(material_type::volumetric, {0.5f, 0.5f, 0.5f}, 0);
  auto wo = direction_at(normal, 40);
  CHECK(sample_delta(fog, normal, wo, 0.3f) == -wo);
  CHECK(eval_delta(fog, normal, wo, -wo) == vec3f{1, 1, 1});
  CHECK(sample_delta_pdf(fog, normal, wo, -wo) == 1);
  CHECK(sample_delta_pdf(fog, normal, wo, wo) == 0);
}

TEST_CASE("shading: white delta lobes conserve energy") {
  // E[eval/pdf] over the discrete choices is exact: sum of eval.
  auto normal = test_normal;
  auto glass  = make_test_material(material_type::refractive, {1, 1, 1}, 0);
  auto sheet  = make_test_material(material_type::transparent, {1, 1, 1}, 0);
  for (auto degrees : {0.0f, 40.0f, 80.0f, 130.0f, 170.0f}) {
    INFO("outgoing angle = ", degrees);
    auto wo      = direction_at(normal, degrees);
    auto rel_ior = dot(normal, wo) > 0 ? glass.ior : 1 / glass.ior;
    auto wr      = sample_delta(glass, normal, wo, 0.0f);
    auto wt      = sample_delta(glass, normal, wo, 0.99999f);
    auto energy  = eval_delta(glass, normal, wo, wr).x;
    if (wt != wr)
      energy += eval_delta(glass, normal, wo, wt).x * rel_ior * rel_ior;
    CHECK(energy == doctest::Approx(1.0f));
    auto sheet_energy =
        eval_delta(sheet, normal, wo, sample_delta(sheet, normal, wo, 0)).x +
        eval_delta(sheet, normal, wo, -wo).x;
    CHECK(sheet_energy == doctest::Approx(1.0f));
  }
}

// -----------------------------------------------------------------------------
// ROBUSTNESS
// -----------------------------------------------------------------------------

TEST_CASE("shading: no NaN or Inf for grazing and backfacing directions") {
  auto rng    = make_rng(51);
  auto finite = [](vec3f v) { return isfinite(v); };
  // Directions: random, exactly in the tangent plane, within 1e-7 of it,
  // exactly along or against the normal.
  auto make_direction = [&](vec3f normal, int kind) {
    auto tangent = normalize(cross(normal, sample_sphere(rand2f(rng))));
    auto side    = rand1f(rng) < 0.5f ? -1.0f : 1.0f;
    switch (kind) {
      case 0: return sample_sphere(rand2f(rng));
      case 1: return tangent;
      case 2: return normalize(tangent + normal * (side * 1e-7f));
      case 3: return normal * side;
      default: return normalize(tangent + normal * (side * rand1f(rng)));
    }
  };
  auto types =
      std::vector<material_type>{material_type::matte, material_type::glossy,
          material_type::reflective, material_type::transparent,
          material_type::refractive, material_type::subsurface,
          material_type::volumetric, material_type::gltfpbr};
  auto rough_values = std::vector<float>{0, 0.02f, 0.03f, 0.031f, 0.3f, 1};
  auto ior_values   = std::vector<float>{1, 1.0005f, 1.5f, 2.4f};
  auto rn_values    = std::vector<float>{0, 0.5f, 0.99999994f};
  auto count = 0, bad = 0, zero_pdf = 0, sampled = 0;
  for (auto trial = 0; trial < 40000; trial++) {
    auto material         = material_data{};
    material.type         = types[rand1i(rng, (int)types.size())];
    material.roughness    = rough_values[rand1i(rng, (int)rough_values.size())];
    material.ior          = ior_values[rand1i(rng, (int)ior_values.size())];
    material.color        = rand1f(rng) < 0.2f ? vec3f{0, 0, 0}
                            : rand1f(rng) < 0.3f
                                ? vec3f{1, 1, 1}
                                : vec3f{rand1f(rng), rand1f(rng), rand1f(rng)};
    material.metallic     = rand1f(rng) < 0.5f ? rand1i(rng, 2) : rand1f(rng);
    material.scattering   = {rand1f(rng), rand1f(rng), rand1f(rng)};
    material.scanisotropy = rand1f(rng) * 1.8f - 0.9f;
    auto point            = make_material_point(material);
    auto normal           = sample_sphere(rand2f(rng));
    auto outgoing         = make_direction(normal, rand1i(rng, 5));
    auto incoming         = make_direction(normal, rand1i(rng, 5));
    auto rnl = rand1f(rng) < 0.3f ? rn_values[rand1i(rng, 3)] : rand1f(rng);
    auto rn  = rand1f(rng) < 0.3f
                   ? vec2f{rn_values[rand1i(rng, 3)], rn_values[rand1i(rng, 3)]}
                   : rand2f(rng);

    // The first failed property, if any.
    auto failed = (const char*)nullptr;
    auto expect = [&](bool property, const char* name) {
      if (!property && !failed) failed = name;
    };
    auto f = eval_bsdfcos(point, normal, outgoing, incoming);
    auto p = sample_bsdfcos_pdf(point, normal, outgoing, incoming);
    expect(finite(f) && min(f) >= 0, "eval_bsdfcos finite, >= 0");
    expect(std::isfinite(p) && p >= 0, "sample_bsdfcos_pdf finite, >= 0");
    auto fd = eval_delta(point, normal, outgoing, incoming);
    auto pd = sample_delta_pdf(point, normal, outgoing, incoming);
    expect(finite(fd) && min(fd) >= 0, "eval_delta finite, >= 0");
    expect(std::isfinite(pd) && pd >= 0, "sample_delta_pdf finite, >= 0");
    expect(finite(eval_scattering(point, outgoing, incoming)) &&
               std::isfinite(sample_scattering_pdf(point, outgoing, incoming)),
        "scattering finite");
    expect(finite(sample_scattering(point, outgoing, rnl, rn)),
        "sample_scattering finite");

    auto wd = sample_delta(point, normal, outgoing, rnl);
    expect(finite(wd), "sample_delta finite");
    if (wd != vec3f{0, 0, 0}) {
      expect(std::abs(length(wd) - 1) < 1e-4f, "sample_delta unit");
      auto fw = eval_delta(point, normal, outgoing, wd);
      expect(finite(fw) && min(fw) >= 0, "eval_delta(sampled) finite, >= 0");
    }

    auto wi = sample_bsdfcos(point, normal, outgoing, rnl, rn);
    expect(finite(wi), "sample_bsdfcos finite");
    if (wi != vec3f{0, 0, 0}) {
      sampled++;
      expect(std::abs(length(wi) - 1) < 1e-4f, "sample_bsdfcos unit");
      auto fi  = eval_bsdfcos(point, normal, outgoing, wi);
      auto pdf = sample_bsdfcos_pdf(point, normal, outgoing, wi);
      expect(finite(fi) && min(fi) >= 0, "eval_bsdfcos(sampled) finite, >= 0");
      expect(std::isfinite(pdf) && pdf >= 0, "pdf(sampled) finite, >= 0");
      // Away from the horizon a sampled direction has a positive pdf. With
      // rnl = 0, a branch of probability ~1e-16 (Fresnel at ior 1) can be
      // taken and its pdf round to 0.
      if (pdf == 0) {
        zero_pdf++;
        auto grazing = std::abs(dot(normal, outgoing)) < 1e-6f ||
                       std::abs(dot(normal, wi)) < 1e-6f;
        expect(grazing || rnl == 0, "pdf(sampled) > 0");
      }
    }
    if (failed) {
      bad++;
      INFO("type = ", material_type_names[(int)point.type],
          " roughness = ", point.roughness, " ior = ", point.ior,
          " color = ", point.color.x, " ", point.color.y, " ", point.color.z,
          " n.o = ", dot(normal, outgoing), " n.i = ", dot(normal, incoming),
          " sampled n.i = ", dot(normal, wi));
      CHECK_MESSAGE(false, std::string(failed));
    }
    count++;
  }
  CHECK(bad == 0);
  CHECK(sampled > 10000);
  MESSAGE("fuzz: ", count, " cases, ", sampled, " sampled, ", zero_pdf,
      " grazing samples with pdf 0");
}

// -----------------------------------------------------------------------------
// VOLUMES
// -----------------------------------------------------------------------------

TEST_CASE("shading: Henyey-Greenstein phase function") {
  auto outgoing = normalize(vec3f{0.2f, 0.5f, -0.7f});
  for (auto g : {-0.5f, 0.0f, 0.7f}) {
    INFO("g = ", g);
    auto result = test_directions(
        -outgoing, chi2_samples, 61,
        [&](rng_state& rng) {
          return sample_phasefunction(g, outgoing, rand2f(rng));
        },
        [&](vec3f incoming) {
          return sample_phasefunction_pdf(g, outgoing, incoming);
        });
    CHECK(result.pdf_integral == doctest::Approx(1.0).epsilon(1e-4));
    CHECK(result.valid_fraction == 1);
    CHECK(result.chi2.pvalue > min_pvalue);
    // mean cosine between -outgoing and incoming is g
    auto rng = make_rng(62);
    auto sum = 0.0;
    for (auto s = 0; s < 100000; s++) {
      sum += -dot(outgoing, sample_phasefunction(g, outgoing, rand2f(rng)));
    }
    CHECK(sum / 100000 == doctest::Approx(g).scale(1).epsilon(0.01));
  }
  // scattering = albedo * density * phase
  auto medium         = material_point{};
  medium.type         = material_type::volumetric;
  medium.density      = {2, 4, 8};
  medium.scattering   = {0.5f, 0.5f, 0.25f};
  medium.scanisotropy = 0.3f;
  auto wi             = normalize(vec3f{1, 0, 0.3f});
  auto phase          = eval_phasefunction(0.3f, outgoing, wi);
  auto scattering     = eval_scattering(medium, outgoing, wi);
  CHECK(scattering.x == doctest::Approx(phase));
  CHECK(scattering.z == doctest::Approx(2 * phase));
  CHECK(sample_scattering_pdf(medium, outgoing, wi) == doctest::Approx(phase));
  medium.density = {0, 0, 0};
  CHECK(eval_scattering(medium, outgoing, wi) == vec3f{0, 0, 0});
  CHECK(sample_scattering(medium, outgoing, 0.5f, {0.5f, 0.5f}) ==
        vec3f{0, 0, 0});
}

TEST_CASE("shading: transmittance sampling matches its pdf") {
  auto transmittance = eval_transmittance({1, 2, 0}, 0.5f);
  CHECK(transmittance.x == doctest::Approx(std::exp(-0.5f)));
  CHECK(transmittance.y == doctest::Approx(std::exp(-1.0f)));
  CHECK(transmittance.z == 1);

  for (auto density : {vec3f{0.5f, 1, 2}, vec3f{3, 0, 1}}) {
    INFO("density = ", density.x, " ", density.y, " ", density.z);
    auto max_distance = 1.5f;
    auto bins         = 60;
    auto samples      = 200000;
    auto observed     = std::vector<double>(bins + 1, 0.0);
    auto expected     = std::vector<double>(bins + 1, 0.0);
    auto rng          = make_rng(71);
    auto out_of_range = 0;
    for (auto s = 0; s < samples; s++) {
      auto rl = rand1f(rng);
      auto distance =
          sample_transmittance(density, max_distance, rl, rand1f(rng));
      if (!(distance >= 0 && distance <= max_distance)) {
        out_of_range++;
      } else if (distance == max_distance) {
        observed[bins] += 1;
      } else {
        observed[std::min((int)(distance / max_distance * bins), bins - 1)] +=
            1;
      }
    }
    CHECK(out_of_range == 0);
    auto gl    = gauss_legendre(8);
    auto width = (double)max_distance / bins;
    auto total = 0.0;
    for (auto b = 0; b < bins; b++) {
      auto integral = 0.0;
      for (auto k = 0; k < 8; k++) {
        auto distance = (b + (gl.nodes[k] + 1) / 2) * width;
        integral +=
            gl.weights[k] / 2 * width *
            sample_transmittance_pdf(density, (float)distance, max_distance);
      }
      expected[b] = integral * samples;
      total += integral;
    }
    auto surface =
        sample_transmittance_pdf(density, max_distance, max_distance);
    expected[bins] = surface * samples;
    total += surface;
    CHECK(total == doctest::Approx(1.0).epsilon(1e-5));
    auto result = chi2_test(observed, expected);
    INFO("chi2 = ", result.chi2, " dof = ", result.dof, " p = ", result.pvalue);
    CHECK(result.pvalue > min_pvalue);
    CHECK(result.unexpected == 0);
  }
}
