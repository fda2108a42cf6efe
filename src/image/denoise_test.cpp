// Tests of the denoiser on synthetic renders with a known truth: a
// piecewise-constant albedo times smooth shading plus Gaussian noise of known
// variance, the two half buffers drawn independently.

#include "denoise.h"

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "../math/random.h"

namespace implicit {

// A synthetic render and its truth.
struct synthetic_render {
  denoise_buffers    buffers = {};
  std::vector<vec3f> truth   = {};
};

// A standard normal number (Box-Muller), two draws in named locals.
static float rand_normal(rng_state& rng) {
  auto u1 = rand1f(rng);
  auto u2 = rand1f(rng);
  return std::sqrt(-2 * std::log(1 - u1)) * std::cos(2 * pif * u2);
}

// Albedo of 12-pixel tiles from a palette, shading by a normal that tilts
// slowly across the image, depth of a tilted plane; every sample adds
// Gaussian noise of standard deviation sigma, `samples` samples per pixel.
static synthetic_render make_synthetic(
    int width, int height, float sigma, int samples, uint64_t seed) {
  const vec3f palette[] = {{0.8f, 0.2f, 0.1f}, {0.2f, 0.6f, 0.3f},
      {0.9f, 0.9f, 0.9f}, {0.1f, 0.2f, 0.7f}, {0.5f, 0.4f, 0.1f}};
  auto        render    = synthetic_render{};
  auto&       buffers   = render.buffers;
  auto        count     = (size_t)width * height;
  buffers.width = width, buffers.height = height;
  for (auto* buffer : {&buffers.color, &buffers.color_a, &buffers.color_b,
           &buffers.variance, &buffers.albedo, &buffers.normal, &render.truth})
    buffer->resize(count);
  buffers.depth.resize(count);
  buffers.samples.assign(count, samples);
  auto rng      = make_rng(seed);
  auto half_var = sigma * sigma / (samples / 2);
  for (auto y = 0; y < height; y++)
    for (auto x = 0; x < width; x++) {
      auto i      = (size_t)y * width + x;
      auto albedo = palette[((x / 12) * 3 + (y / 12) * 7) % 5];
      auto normal = normalize(
          vec3f{std::sin(x * 0.05f) * 0.6f, std::cos(y * 0.04f) * 0.5f, 1});
      auto shade =
          0.2f + std::max(dot(normal, normalize({0.3f, 0.4f, 1})), 0.0f);
      auto truth        = albedo * shade;
      render.truth[i]   = truth;
      buffers.albedo[i] = albedo;
      buffers.normal[i] = normal;
      buffers.depth[i]  = 5 + 0.01f * y;
      for (auto* half : {&buffers.color_a, &buffers.color_b}) {
        auto noise =
            vec3f{rand_normal(rng), rand_normal(rng), rand_normal(rng)};
        (*half)[i] = truth + noise * std::sqrt(half_var);
      }
      buffers.color[i]    = (buffers.color_a[i] + buffers.color_b[i]) * 0.5f;
      buffers.variance[i] = vec3f{1, 1, 1} * (sigma * sigma / samples);
    }
  return render;
}

// A render of constant features (normal +z, depth 5, albedo 0.5 unless
// `pixel` sets it) whose pixel (x, y) has the truth and the variance of a
// half's mean that pixel(x, y, truth, albedo, half_variance) sets; each half
// adds Gaussian noise of that variance, drawn from `seed`.
template <typename Pixel>
static synthetic_render make_custom(
    int width, int height, uint64_t seed, Pixel&& pixel) {
  auto  render  = make_synthetic(width, height, 0.5f, 16, seed);
  auto& buffers = render.buffers;
  auto  rng     = make_rng(seed);
  for (auto y = 0; y < height; y++)
    for (auto x = 0; x < width; x++) {
      auto i        = (size_t)y * width + x;
      auto truth    = vec3f{0, 0, 0};
      auto albedo   = vec3f{0.5f, 0.5f, 0.5f};
      auto half_var = 0.0f;
      pixel(x, y, truth, albedo, half_var);
      render.truth[i]   = truth;
      buffers.albedo[i] = albedo;
      buffers.normal[i] = {0, 0, 1};
      buffers.depth[i]  = 5;
      for (auto* half : {&buffers.color_a, &buffers.color_b}) {
        auto noise =
            vec3f{rand_normal(rng), rand_normal(rng), rand_normal(rng)};
        (*half)[i] = truth + noise * std::sqrt(half_var);
      }
      buffers.color[i]    = (buffers.color_a[i] + buffers.color_b[i]) * 0.5f;
      buffers.variance[i] = vec3f{1, 1, 1} * (half_var / 2);
    }
  return render;
}

// Relative MSE: mean over pixels and channels of (x - t)^2 / (t^2 + 0.01).
static double rel_mse(
    const std::vector<vec3f>& image, const std::vector<vec3f>& truth) {
  auto sum = 0.0;
  for (size_t i = 0; i < image.size(); i++)
    for (auto c = 0; c < 3; c++) {
      double d = at(image[i], c) - at(truth[i], c), t = at(truth[i], c);
      sum += d * d / (t * t + 0.01);
    }
  return sum / (3.0 * image.size());
}

// Mean of all channels of all pixels.
static double image_mean(const std::vector<vec3f>& image) {
  auto sum = 0.0;
  for (auto& p : image) sum += (double)p.x + p.y + p.z;
  return sum / (3.0 * image.size());
}

// The methods under test with their names.
static const denoise_method all_methods[] = {
    denoise_method::nfor, denoise_method::nlm, denoise_method::ttest};

// The default parameters of a method.
static denoise_params method_params(denoise_method method) {
  auto params   = denoise_params{};
  params.method = method;
  return params;
}

// relMSE of a method's defaults, and of the same with `setting` at 0.
template <typename T>
static std::pair<double, double> rel_mse_with_and_without(
    const synthetic_render& render, denoise_method method,
    T denoise_params::*setting) {
  auto params = method_params(method);
  auto with   = rel_mse(denoise_image(render.buffers, params), render.truth);
  params.*setting = 0;
  auto without = rel_mse(denoise_image(render.buffers, params), render.truth);
  return {with, without};
}

TEST_CASE("denoise lowers the relative MSE of a noisy render") {
  auto render = make_synthetic(96, 72, 0.5f, 16, 7);
  auto noisy  = rel_mse(render.buffers.color, render.truth);
  for (auto method : all_methods) {
    auto params = method_params(method);
    auto denoised =
        rel_mse(denoise_image(render.buffers, params), render.truth);
    INFO(denoise_method_names[(int)method], " noisy ", noisy, " denoised ",
        denoised);
    CHECK(denoised * 10 < noisy);
  }
}

TEST_CASE("denoise keeps a sharp albedo edge sharp") {
  // Left half albedo 0.2, right half 0.8, smooth shading: the step between
  // the two columns at the edge keeps 90% of its true height on average.
  auto edge   = 32;
  auto render = make_custom(
      64, 48, 3, [&](int x, int y, vec3f& truth, vec3f& albedo, float& var) {
        albedo = vec3f{1, 1, 1} * (x < edge ? 0.2f : 0.8f);
        truth  = albedo * (0.6f + 0.3f * std::sin(y * 0.1f));
        var    = 0.25f / 8;
      });
  auto& buffers = render.buffers;
  auto  width   = buffers.width;
  for (auto method : all_methods) {
    auto params   = method_params(method);
    auto denoised = denoise_image(buffers, params);
    auto step = 0.0, truth = 0.0, noisy = 0.0;
    for (auto y = 0; y < buffers.height; y++) {
      auto left = (size_t)y * width + edge - 1, right = left + 1;
      step += mean(denoised[right] - denoised[left]);
      truth += mean(render.truth[right] - render.truth[left]);
      noisy += mean(buffers.color[right] - buffers.color[left]);
    }
    INFO(denoise_method_names[(int)method], " step ", step, " truth ", truth,
        " noisy ", noisy);
    CHECK(step > 0.9 * truth);
    CHECK(step < 1.1 * truth);
  }
}

TEST_CASE("denoise: a low strength keeps highlights the features miss") {
  // Constant features; the colour has bumps 0.5 high, about 5 pixels wide
  // (glossy highlights no feature explains), under noise of 0.1 per pixel.
  // NL-means at k = 1 averages bumps and valleys whose patches differ by
  // less than the noise allows; the runs at the low strength keep them where
  // SURE says they are better.
  auto render = make_custom(
      96, 72, 5, [](int x, int y, vec3f& truth, vec3f&, float& var) {
        auto bump = std::max(std::sin(x * 0.6f) * std::sin(y * 0.6f), 0.0f);
        truth     = vec3f{1, 1, 1} * (0.4f + 0.5f * bump * bump);
        var       = 0.02f;
      });
  auto& buffers       = render.buffers;
  auto  params        = denoise_params{};
  auto  both          = rel_mse(denoise_image(buffers, params), render.truth);
  params.low_strength = 0;
  auto one            = rel_mse(denoise_image(buffers, params), render.truth);
  auto raw            = rel_mse(buffers.color, render.truth);
  INFO("raw ", raw, " strength 1 only ", one, " with 0.5 ", both);
  CHECK(both * 1.5 < one);  // measured 2.5x
  CHECK(both * 4 < raw);
}

TEST_CASE("denoise: a noisy column does not lend its variance") {
  // Constant features, quiet colour 0.3 left of a step and 0.6 right of it,
  // and between them a column of pixels whose mean is very noisy (the
  // sample variance of edge pixels that samples cover or miss, of
  // highlights). The quiet columns beside it keep their values: each
  // pixel's NL-means distances are in units of its own variance, which a
  // 3x3 mean of the variance made the noisy column's (then each quiet side
  // took in the other side).
  auto edge = 32;
  auto render =
      make_custom(64, 48, 9, [&](int x, int, vec3f& truth, vec3f&, float& var) {
        truth = vec3f{1, 1, 1} * (x < edge ? 0.3f : x > edge ? 0.6f : 0.45f);
        var   = x == edge ? 0.3f : 0.0002f;
      });
  auto& buffers = render.buffers;
  auto  width   = buffers.width;
  for (auto method : all_methods) {
    auto params   = method_params(method);
    auto denoised = denoise_image(buffers, params);
    auto error    = 0.0;  // mean |error| of the columns beside the step
    for (auto y = 0; y < buffers.height; y++)
      for (auto x : {edge - 1, edge + 1}) {
        auto i = (size_t)y * width + x;
        error += std::abs(mean(denoised[i] - render.truth[i]));
      }
    error /= 2 * buffers.height;
    INFO(denoise_method_names[(int)method], " error beside the step ", error);
    CHECK(error < 0.02);  // 0.012-0.016; 0.026-0.077 with the 3x3 mean
  }
}

TEST_CASE("denoise: runs are blended by the picks around") {
  // Where two runs' error estimates are close, the pick switches from pixel
  // to pixel and leaves the runs' differences as noise; blending by the
  // picks over 7x7 pixels smooths it (measured: nlm 1.30x, nfor 1.15x,
  // ttest 1.03x lower relMSE).
  auto render = make_synthetic(96, 72, 0.5f, 16, 17);
  for (auto method : all_methods) {
    auto [blended, picked] =
        rel_mse_with_and_without(render, method, &denoise_params::blend_radius);
    INFO(denoise_method_names[(int)method], " picked ", picked, " blended ",
        blended);
    CHECK(blended * (method == denoise_method::ttest ? 1 : 1.1) < picked);
  }
}

TEST_CASE("denoise: a texture is filtered as lighting times albedo") {
  // An albedo that changes at every pixel (a fine texture) under smooth
  // lighting: the albedo weights keep each pixel from its neighbours, so
  // the colour keeps its noise; colour / albedo is the smooth lighting,
  // which the filters average, then multiply back. (The regression, nfor,
  // already follows the albedo; the t-test keeps more of the noise.)
  auto render = make_custom(
      96, 72, 11, [](int x, int y, vec3f& truth, vec3f& albedo, float& var) {
        albedo = vec3f{1, 1, 1} * (0.5f + 0.4f * std::sin(x * 2.1f + y * 1.3f));
        truth  = albedo * (0.8f + 0.2f * std::sin(y * 0.05f));
        var    = 0.02f;
      });
  for (auto method : all_methods) {
    auto [lighting, colour] =
        rel_mse_with_and_without(render, method, &denoise_params::demodulate);
    INFO(denoise_method_names[(int)method], " colour ", colour, " lighting ",
        lighting);
    CHECK(lighting * (method == denoise_method::nlm ? 2 : 1.2) < colour);
  }
}

TEST_CASE("denoise: a firefly on an edge averages with its neighbours") {
  // Albedo 0.2 left of a step and 0.8 right of it; one pixel on the step
  // has the mixed albedo 0.5 (a corner of a checker), so its features are
  // far from every neighbour's. It holds a firefly: a sample 16 x 1.5 high
  // among 16 (its mean 1.5 too high, its variance 1.5^2). The features kept
  // it where it was; as an outlier it averages with the neighbours its
  // colour distances allow, which its variance makes most of them.
  auto edge   = 32;
  auto row    = 24;
  auto render = make_custom(
      64, 48, 13, [&](int x, int y, vec3f& truth, vec3f& albedo, float& var) {
        auto mixed = x == edge && y == row;
        albedo     = vec3f{1, 1, 1} * (mixed ? 0.5f : x < edge ? 0.2f : 0.8f);
        truth      = albedo * 0.7f;
        var        = 0.002f;
      });
  auto& buffers = render.buffers;
  auto  pixel   = (size_t)row * buffers.width + edge;
  auto  firefly = vec3f{1.5f, 1.5f, 1.5f};
  buffers.color_a[pixel] += 2 * firefly;
  buffers.color[pixel] += firefly;
  buffers.variance[pixel] += firefly * firefly;
  for (auto method : all_methods) {
    auto params          = method_params(method);
    auto outlier         = denoise_image(buffers, params)[pixel];
    params.outlier_ratio = 0;
    auto kept            = denoise_image(buffers, params)[pixel];
    auto truth           = render.truth[pixel];
    INFO(denoise_method_names[(int)method], " truth ", truth.x, " as outlier ",
        outlier.x, " features kept ", kept.x);
    CHECK(max(abs(outlier - truth)) < 0.3f);
    CHECK(max(abs(kept - truth)) > 1.0f);
  }
}

TEST_CASE("denoise keeps the mean within the noise") {
  // The noise of the image mean: sqrt(sum of variances) / pixels.
  auto render = make_synthetic(96, 72, 0.5f, 16, 5);
  auto pixels = (double)render.truth.size() * 3;
  auto noise  = std::sqrt(pixels * 0.25 / 16) / pixels;
  auto truth  = image_mean(render.truth);
  auto noisy  = image_mean(render.buffers.color);
  CHECK(std::abs(noisy - truth) < 4 * noise);
  for (auto method : all_methods) {
    auto params   = method_params(method);
    auto denoised = image_mean(denoise_image(render.buffers, params));
    INFO(denoise_method_names[(int)method], " truth ", truth, " noisy ", noisy,
        " denoised ", denoised, " noise ", noise);
    CHECK(std::abs(denoised - truth) < 4 * noise);
  }
}

TEST_CASE("denoise keeps a constant image constant") {
  auto buffers  = denoise_buffers{};
  buffers.width = 20, buffers.height = 13;
  auto count = (size_t)buffers.width * buffers.height;
  auto value = vec3f{0.3f, 1.7f, 12.5f};
  buffers.color.assign(count, value);
  buffers.color_a.assign(count, value);
  buffers.color_b.assign(count, value);
  buffers.variance.assign(count, {0.01f, 0.02f, 0.0f});
  // Features that vary: the regression must still give the constant. A
  // constant albedo: the filters see colour / albedo, which an albedo that
  // varies under a constant colour would make vary.
  for (size_t i = 0; i < count; i++) {
    buffers.albedo.push_back(vec3f{0.3f, 0.6f, 0.9f});
    buffers.normal.push_back(normalize(vec3f{(float)(i % 5), 1, 2}));
    buffers.depth.push_back(1 + (float)(i % 11));
  }
  for (auto method : all_methods) {
    auto params   = method_params(method);
    auto denoised = denoise_image(buffers, params);
    REQUIRE(denoised.size() == count);
    auto exact = true;
    for (auto& p : denoised) exact = exact && p == value;
    INFO(denoise_method_names[(int)method]);
    CHECK(exact);
  }
}

TEST_CASE("denoise does not spread NaN or inf") {
  // Non-finite colours (and a non-finite variance or albedo) make pixels
  // missing: every output is finite, a missing pixel is filled from its
  // neighbours, and the others change by less than the noise (they lose a
  // neighbour).
  auto render              = make_synthetic(40, 32, 0.5f, 16, 9);
  auto broken              = render.buffers;
  auto nan                 = std::numeric_limits<float>::quiet_NaN();
  auto inf                 = std::numeric_limits<float>::infinity();
  auto bad                 = (size_t)10 * 40 + 14;
  broken.color[bad]        = {nan, 0, 0};
  broken.color_a[bad]      = {inf, 1, 1};
  broken.variance[bad + 1] = {0, inf, 0};
  broken.albedo[bad + 2]   = {nan, nan, nan};
  broken.depth[bad + 3]    = nan;
  for (auto method : all_methods) {
    auto params   = method_params(method);
    auto clean    = denoise_image(render.buffers, params);
    auto denoised = denoise_image(broken, params);
    auto finite   = true;
    auto change   = 0.0f;
    for (size_t i = 0; i < denoised.size(); i++) {
      finite = finite && isfinite(denoised[i]);
      if (i < bad || i > bad + 3)
        change = std::max(change, max(abs(denoised[i] - clean[i])));
    }
    INFO(denoise_method_names[(int)method], " change ", change);
    CHECK(finite);
    CHECK(change < 0.08f);
    for (auto i = bad; i < bad + 3; i++)
      CHECK(max(abs(denoised[i] - render.truth[i])) < 0.15f);
  }
}

TEST_CASE("denoise works without optional buffers") {
  auto render     = make_synthetic(64, 48, 0.5f, 16, 13);
  auto noisy      = rel_mse(render.buffers.color, render.truth);
  auto full       = render.buffers;
  auto color_only = denoise_buffers{full.width, full.height, full.color};
  auto halves_only =
      denoise_buffers{full.width, full.height, {}, full.color_a, full.color_b};
  auto no_features   = full;
  no_features.albedo = {}, no_features.normal = {}, no_features.depth = {};
  for (auto method : all_methods) {
    auto params = method_params(method);
    for (auto& buffers : {color_only, halves_only, no_features}) {
      auto denoised = rel_mse(denoise_image(buffers, params), render.truth);
      INFO(denoise_method_names[(int)method], " noisy ", noisy, " denoised ",
          denoised);
      CHECK(denoised * 3 < noisy);
    }
  }
}

TEST_CASE("denoise gives the same bytes at 1 and 2 threads") {
  auto render = make_synthetic(50, 37, 0.5f, 16, 17);
  for (auto method : all_methods) {
    auto params = method_params(method);
    auto one = std::vector<vec3f>{}, two = std::vector<vec3f>{};
    {
      auto control =
          tbb::global_control(tbb::global_control::max_allowed_parallelism, 1);
      one = denoise_image(render.buffers, params);
    }
    {
      auto control =
          tbb::global_control(tbb::global_control::max_allowed_parallelism, 2);
      two = denoise_image(render.buffers, params);
    }
    REQUIRE(one.size() == two.size());
    INFO(denoise_method_names[(int)method]);
    CHECK(std::memcmp(one.data(), two.data(), one.size() * sizeof(vec3f)) == 0);
  }
}

TEST_CASE("denoise rejects buffers of the wrong size and bad strengths") {
  auto buffers  = denoise_buffers{};
  buffers.width = 4, buffers.height = 3;
  CHECK_THROWS_AS(denoise_image(buffers), std::invalid_argument);
  buffers.color.resize(12);
  CHECK(denoise_image(buffers).size() == 12);
  buffers.albedo.resize(11);
  CHECK_THROWS_AS(denoise_image(buffers), std::invalid_argument);
  buffers.albedo = {};
  buffers.color_a.resize(12);
  CHECK_THROWS_AS(denoise_image(buffers), std::invalid_argument);
  buffers.color_a = {};
  auto params     = denoise_params{};
  params.strength = 0;  // would divide the distances by 0
  CHECK_THROWS_AS(denoise_image(buffers, params), std::invalid_argument);
  params.strength     = 1;
  params.low_strength = -1;
  CHECK_THROWS_AS(denoise_image(buffers, params), std::invalid_argument);
  params.low_strength = 0;
  params.blend_radius = -1;
  CHECK_THROWS_AS(denoise_image(buffers, params), std::invalid_argument);
  params.blend_radius = 0;
  params.demodulate   = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_AS(denoise_image(buffers, params), std::invalid_argument);
  params.demodulate    = 0;
  params.outlier_ratio = -1;
  CHECK_THROWS_AS(denoise_image(buffers, params), std::invalid_argument);
  params.outlier_ratio = 0;
  CHECK_NOTHROW(denoise_image(buffers, params));
  CHECK(parse_denoise_method("nlm") == denoise_method::nlm);
  CHECK_THROWS_AS(parse_denoise_method("oidn"), std::invalid_argument);
}

}  // namespace implicit
