// # implicit: denoising
//
// The filters see the lighting: colour / (albedo + a floor), multiplied
// back at the end. One engine visits, for every pixel p and every neighbour
// q in its window, the weight w(p, q) of a method (NL-means times feature
// weights, or a t-test times feature weights); the filters accumulate what they
// need from the weights (a weighted mean, or the moments of a first-order
// regression). One visit serves several runs (two window sizes, and for nlm two
// NL-means strengths); each pixel blends the runs by their shares of the
// pixels around whose SURE error estimate they minimise.
//
// The engine runs over blocks of rows in parallel, offset by offset, and
// computes every weight from fixed coordinates only: each pixel sums its
// neighbours in the same order whatever the blocks, so the output is the same
// at any thread count.

#include "denoise.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace implicit {

namespace {

// -----------------------------------------------------------------------------
// INPUTS
// -----------------------------------------------------------------------------

// Features per pixel: albedo (3), normal (3), log depth (1).
constexpr int max_features = 7;
// Rows per parallel task.
constexpr int block_rows = 8;
// SURE estimates are averaged over (2 sure_radius + 1)^2 pixels.
constexpr int sure_radius = 3;
// A depth this many times the farthest hit stands for "no hit".
constexpr float no_hit_depth_factor = 16;

// The denoiser's loops along a row, compiled twice: for AVX2 (8 floats a
// vector) and for the baseline x86-64 (SSE2, 4); the loader picks one for
// the CPU (GCC's and Clang's target_clones, which take no templates). Each
// loop works element by element and AVX2 alone brings no fused
// multiply-add, so both give the same floats.
#define IMPLICIT_WIDE_LOOPS __attribute__((target_clones("avx2", "default")))

// A float per pixel with `pad` replicated pixels around the image: windows
// and patches near the border read clamped coordinates without tests, and
// loops over a row run over contiguous floats (the compiler vectorises them).
struct padded_plane {
  int                pad    = 0;
  int                stride = 0;
  std::vector<float> data   = {};
  // Pointer to pixel (0, y); y and x may be up to pad outside the image.
  const float* row(int y) const {
    return data.data() + (size_t)(y + pad) * stride + pad;
  }
};

// A padded plane of value(i), i the index of a pixel of the image.
template <typename Value>
padded_plane make_plane(int width, int height, int pad, Value&& value) {
  auto plane = padded_plane{pad, width + 2 * pad, {}};
  auto rows  = height + 2 * pad;
  plane.data = std::vector<float>((size_t)rows * plane.stride);
  for (auto y = 0; y < rows; y++)
    for (auto x = 0; x < plane.stride; x++) {
      auto i = (size_t)std::clamp(y - pad, 0, height - 1) * width +
               std::clamp(x - pad, 0, width - 1);
      plane.data[(size_t)y * plane.stride + x] = value(i);
    }
  return plane;
}

// Three planes, one per channel.
using padded_color = std::array<padded_plane, 3>;

// The buffers after checks: missing values zeroed and flagged, variance
// estimated when absent and smoothed, features in units of their sigma;
// then the same as padded planes for the filters.
struct guide_data {
  int                width    = 0;
  int                height   = 0;
  std::vector<vec3f> color    = {};
  std::vector<vec3f> half_a   = {};  // both halves empty or both filled
  std::vector<vec3f> half_b   = {};
  std::vector<vec3f> variance = {};  // of the full mean
  // 1 where colour, halves, variance and albedo are finite.
  std::vector<uint8_t> valid = {};
  // When demodulating, albedo + floor per pixel: colour, halves and variance
  // above are divided by it (variance by its square), and the colour before
  // that; both empty otherwise.
  std::vector<vec3f> scale     = {};
  std::vector<vec3f> modulated = {};
  // Colour distances below this count as zero (scale of the image).
  float epsilon = 0;
  // Features: nfeatures per pixel; when has_depth the last one is log depth,
  // compared to the plane through the pixel (depth_gradient per pixel step).
  int                nfeatures      = 0;
  bool               has_depth      = false;
  std::vector<float> features       = {};
  std::vector<vec2f> depth_gradient = {};
  // Planes, padded by the window and patch radii.
  padded_color              color_planes    = {};
  padded_color              half_a_planes   = {};
  padded_color              half_b_planes   = {};
  padded_color              variance_planes = {};
  padded_plane              valid_plane     = {};
  std::vector<padded_plane> feature_planes  = {};
  padded_plane              gradient_x      = {};
  padded_plane              gradient_y      = {};
  padded_plane              trust           = {};  // feature weight scale
};

// A buffer that is empty or has one entry per pixel.
template <typename T>
void check_size(const std::vector<T>& buffer, size_t count, const char* name) {
  if (!buffer.empty() && buffer.size() != count)
    throw std::invalid_argument(std::string("denoise_image: buffer ") + name +
                                " has " + std::to_string(buffer.size()) +
                                " pixels, expected " + std::to_string(count));
}

// Size checks of every buffer.
void check_buffers(const denoise_buffers& buffers) {
  if (buffers.width < 0 || buffers.height < 0)
    throw std::invalid_argument("denoise_image: negative image size");
  auto count = (size_t)buffers.width * (size_t)buffers.height;
  check_size(buffers.color, count, "color");
  check_size(buffers.color_a, count, "color_a");
  check_size(buffers.color_b, count, "color_b");
  check_size(buffers.variance, count, "variance");
  check_size(buffers.albedo, count, "albedo");
  check_size(buffers.normal, count, "normal");
  check_size(buffers.depth, count, "depth");
  check_size(buffers.samples, count, "samples");
  if (buffers.color_a.empty() != buffers.color_b.empty())
    throw std::invalid_argument(
        "denoise_image: color_a and color_b must both be given or both empty");
  if (count != 0 && buffers.color.empty() && buffers.color_a.empty())
    throw std::invalid_argument("denoise_image: no color buffer");
}

// Colour, halves and validity; invalid pixels hold zeros.
void make_colors(const denoise_buffers& buffers, guide_data& guide) {
  auto count   = (size_t)guide.width * guide.height;
  auto halves  = !buffers.color_a.empty();
  guide.color  = std::vector<vec3f>(count);
  guide.valid  = std::vector<uint8_t>(count, 1);
  guide.half_a = halves ? buffers.color_a : std::vector<vec3f>{};
  guide.half_b = halves ? buffers.color_b : std::vector<vec3f>{};
  for (size_t i = 0; i < count; i++) {
    auto color = buffers.color.empty()
                     ? (buffers.color_a[i] + buffers.color_b[i]) * 0.5f
                     : buffers.color[i];
    // A non-finite albedo too: the colour is filtered divided by it.
    auto valid = isfinite(color) &&
                 (!halves || (isfinite(buffers.color_a[i]) &&
                                 isfinite(buffers.color_b[i]))) &&
                 (buffers.variance.empty() || isfinite(buffers.variance[i])) &&
                 (buffers.albedo.empty() || isfinite(buffers.albedo[i]));
    guide.valid[i] = valid ? 1 : 0;
    guide.color[i] = valid ? color : vec3f{0, 0, 0};
    if (halves && !valid) guide.half_a[i] = guide.half_b[i] = {0, 0, 0};
  }
}

// Variance of the mean per pixel: the buffer as it is, else the halves'
// squared difference / 4 (one degree of freedom: then a 3x3 mean over valid
// pixels), else one global estimate from neighbouring differences. The
// buffer's sample variance is not smoothed: a 3x3 mean spreads the large
// variance of edge and highlight pixels to their neighbours, whose NL-means
// distances then let them average across the edge (64 spp, README: relMSE
// 3-24% lower on three scenes, within 1% on the fourth).
void make_variance(const denoise_buffers& buffers, guide_data& guide) {
  auto count = guide.color.size();
  if (!buffers.variance.empty()) {
    guide.variance = std::vector<vec3f>(count);
    for (size_t i = 0; i < count; i++)
      guide.variance[i] =
          guide.valid[i] ? max(buffers.variance[i], 0.0f) : vec3f{};
    return;
  }
  auto width = guide.width, height = guide.height;
  auto raw = std::vector<vec3f>(count);
  if (!guide.half_a.empty()) {
    for (size_t i = 0; i < raw.size(); i++) {
      auto d = guide.half_a[i] - guide.half_b[i];
      raw[i] = d * d * 0.25f;
    }
  } else {
    // The median of (c_x - c_x+1)^2 / 2 over horizontal pairs, divided by
    // the median of chi-square with one degree of freedom (0.4549).
    std::vector<float> diffs[3];
    for (auto y = 0; y < height; y++)
      for (auto x = 0; x + 1 < width; x++) {
        auto i = (size_t)y * width + x;
        if (!guide.valid[i] || !guide.valid[i + 1]) continue;
        auto d = guide.color[i] - guide.color[i + 1];
        for (auto c = 0; c < 3; c++) diffs[c].push_back(at(d, c) * at(d, c));
      }
    auto global = vec3f{0, 0, 0};
    for (auto c = 0; c < 3; c++) {
      if (diffs[c].empty()) continue;
      auto mid = diffs[c].begin() + diffs[c].size() / 2;
      std::nth_element(diffs[c].begin(), mid, diffs[c].end());
      at(global, c) = *mid / 2 / 0.4549f;
    }
    for (auto& v : raw) v = global;
  }
  guide.variance = std::vector<vec3f>(raw.size());
  for (auto y = 0; y < height; y++)
    for (auto x = 0; x < width; x++) {
      auto sum = vec3f{0, 0, 0};
      auto n   = 0;
      for (auto j = std::max(y - 1, 0); j <= std::min(y + 1, height - 1); j++)
        for (auto i = std::max(x - 1, 0); i <= std::min(x + 1, width - 1);
             i++) {
          if (!guide.valid[(size_t)j * width + i]) continue;
          sum += raw[(size_t)j * width + i];
          n++;
        }
      guide.variance[(size_t)y * width + x] = n ? sum / (float)n : vec3f{};
    }
}

// The mean of the finite albedos of the 3x3 pixels around (x, y), for a
// pixel whose own is missing (0 when none is finite).
vec3f neighbour_albedo(const denoise_buffers& buffers, int x, int y) {
  auto width = buffers.width, height = buffers.height;
  auto sum = vec3f{0, 0, 0};
  auto n   = 0.0f;
  for (auto j = std::max(y - 1, 0); j <= std::min(y + 1, height - 1); j++)
    for (auto i = std::max(x - 1, 0); i <= std::min(x + 1, width - 1); i++) {
      auto albedo = buffers.albedo[(size_t)j * width + i];
      if (isfinite(albedo)) sum += max(albedo, 0.0f), n += 1;
    }
  return n > 0 ? sum / n : vec3f{0, 0, 0};
}

// Divide colour, halves and variance by albedo + params.demodulate (the
// variance by its square): the filters then see lighting, continuous across
// the edges of textures and checkers, where an edge pixel's mixed colour
// matches its mixed albedo (materials, README: 1.3x lower relMSE).
void demodulate(const denoise_buffers& buffers, const denoise_params& params,
    guide_data& guide) {
  if (params.demodulate <= 0 || buffers.albedo.empty()) return;
  guide.modulated = guide.color;
  guide.scale     = std::vector<vec3f>(guide.color.size());
  for (size_t i = 0; i < guide.scale.size(); i++) {
    auto albedo = buffers.albedo[i];
    if (!isfinite(albedo))
      albedo = neighbour_albedo(
          buffers, (int)(i % guide.width), (int)(i / guide.width));
    auto scale        = max(albedo, 0.0f) + params.demodulate;
    guide.scale[i]    = scale;
    guide.color[i]    = guide.color[i] / scale;
    guide.variance[i] = guide.variance[i] / (scale * scale);
    if (!guide.half_a.empty()) {
      guide.half_a[i] = guide.half_a[i] / scale;
      guide.half_b[i] = guide.half_b[i] / scale;
    }
  }
}

// Log depth per pixel, in units of depth_sigma; a missing hit is far.
std::vector<float> make_log_depth(
    const denoise_buffers& buffers, const denoise_params& params) {
  auto farthest = 0.0f;
  for (auto z : buffers.depth)
    if (std::isfinite(z) && z > 0) farthest = std::max(farthest, z);
  if (farthest == 0) return {};
  auto log_depth = std::vector<float>(buffers.depth.size());
  for (size_t i = 0; i < log_depth.size(); i++) {
    auto z   = buffers.depth[i];
    auto hit = std::isfinite(z) && z > 0;
    log_depth[i] =
        std::log(hit ? z : farthest * no_hit_depth_factor) / params.depth_sigma;
  }
  return log_depth;
}

// The smaller in magnitude of two one-sided differences (0 when their signs
// differ): the slope of the surface on the smooth side of an edge.
float min_mod(float a, float b) {
  if (a * b <= 0) return 0;
  return std::abs(a) < std::abs(b) ? a : b;
}

// Features in units of their sigma, and the depth gradient.
void make_features(const denoise_buffers& buffers, const denoise_params& params,
    guide_data& guide) {
  auto count     = (size_t)guide.width * guide.height;
  auto log_depth = buffers.depth.empty() ? std::vector<float>{}
                                         : make_log_depth(buffers, params);
  auto nf        = (buffers.albedo.empty() ? 0 : 3) +
            (buffers.normal.empty() ? 0 : 3) + (log_depth.empty() ? 0 : 1);
  guide.nfeatures = nf;
  guide.has_depth = !log_depth.empty();
  guide.features  = std::vector<float>(count * nf);
  if (nf == 0) return;
  for (size_t i = 0; i < count; i++) {
    auto f = &guide.features[i * nf];
    auto k = 0;
    if (!buffers.albedo.empty()) {
      auto a = isfinite(buffers.albedo[i]) ? buffers.albedo[i] : vec3f{};
      for (auto c = 0; c < 3; c++) f[k++] = at(a, c) / params.albedo_sigma;
    }
    if (!buffers.normal.empty()) {
      auto n = isfinite(buffers.normal[i]) ? buffers.normal[i] : vec3f{};
      for (auto c = 0; c < 3; c++) f[k++] = at(n, c) / params.normal_sigma;
    }
    if (guide.has_depth) f[k++] = log_depth[i];
  }
  if (!guide.has_depth) return;
  auto width = guide.width, height = guide.height;
  guide.depth_gradient = std::vector<vec2f>(count);
  for (auto y = 0; y < height; y++)
    for (auto x = 0; x < width; x++) {
      auto z  = [&](int i, int j) { return log_depth[(size_t)j * width + i]; };
      auto gx = x > 0 && x + 1 < width
                    ? min_mod(z(x, y) - z(x - 1, y), z(x + 1, y) - z(x, y))
                    : 0.0f;
      auto gy = y > 0 && y + 1 < height
                    ? min_mod(z(x, y) - z(x, y - 1), z(x, y + 1) - z(x, y))
                    : 0.0f;
      guide.depth_gradient[(size_t)y * width + x] = {gx, gy};
    }
}

// Per pixel, how much its feature distances count: 1, less for a pixel
// whose variance is above `ratio` times the median of its 8 neighbours' (an
// outlier sample, a firefly): its colour distances are lenient by its
// variance, and its features (an edge pixel's mixed albedo) should not keep
// it from averaging with its neighbours.
std::vector<float> feature_trust(const guide_data& guide, float ratio) {
  auto width = guide.width, height = guide.height;
  auto trust = std::vector<float>(guide.color.size(), 1.0f);
  if (ratio <= 0) return trust;
  auto level = [&](int x, int y) {
    return mean(guide.variance[(size_t)std::clamp(y, 0, height - 1) * width +
                               std::clamp(x, 0, width - 1)]);
  };
  for (auto y = 0; y < height; y++)
    for (auto x = 0; x < width; x++) {
      float around[8];
      auto  n = 0;
      for (auto dy = -1; dy <= 1; dy++)
        for (auto dx = -1; dx <= 1; dx++)
          if (dx || dy) around[n++] = level(x + dx, y + dy);
      std::nth_element(around, around + 4, around + 8);
      auto own = level(x, y);
      if (own > ratio * around[4])
        trust[(size_t)y * width + x] = ratio * around[4] / own;
    }
  return trust;
}

// The guide of a denoising run, with planes padded for windows of `radius`
// and patches of `patch`.
guide_data make_guide(const denoise_buffers& buffers,
    const denoise_params& params, int radius, int patch) {
  auto guide   = guide_data{};
  guide.width  = buffers.width;
  guide.height = buffers.height;
  make_colors(buffers, guide);
  make_variance(buffers, guide);
  demodulate(buffers, params, guide);
  make_features(buffers, params, guide);
  // Distances of colours below 1e-4 of the mean colour count as noise free.
  auto sum = 0.0, n = 0.0;
  for (size_t i = 0; i < guide.color.size(); i++)
    if (guide.valid[i]) sum += mean(abs(guide.color[i])), n += 1;
  auto scale    = n > 0 ? (float)(sum / n) : 0.0f;
  guide.epsilon = std::max(1e-8f * scale * scale, 1e-20f);
  // Planes.
  auto width = guide.width, height = guide.height, pad = radius + patch;
  auto color_planes = [&](const std::vector<vec3f>& values) {
    auto planes = padded_color{};
    if (values.empty()) return planes;
    for (auto c = 0; c < 3; c++)
      planes[c] = make_plane(
          width, height, pad, [&](size_t i) { return at(values[i], c); });
    return planes;
  };
  guide.color_planes    = color_planes(guide.color);
  guide.half_a_planes   = color_planes(guide.half_a);
  guide.half_b_planes   = color_planes(guide.half_b);
  guide.variance_planes = color_planes(guide.variance);
  guide.valid_plane     = make_plane(
          width, height, pad, [&](size_t i) { return (float)guide.valid[i]; });
  auto nf = (size_t)guide.nfeatures;
  for (size_t k = 0; k < nf; k++)
    guide.feature_planes.push_back(make_plane(width, height, pad,
        [&](size_t i) { return guide.features[i * nf + k]; }));
  auto trust = feature_trust(guide, params.outlier_ratio);
  guide.trust =
      make_plane(width, height, pad, [&](size_t i) { return trust[i]; });
  if (guide.has_depth) {
    guide.gradient_x = make_plane(width, height, pad,
        [&](size_t i) { return guide.depth_gradient[i].x; });
    guide.gradient_y = make_plane(width, height, pad,
        [&](size_t i) { return guide.depth_gradient[i].y; });
  }
  return guide;
}

// -----------------------------------------------------------------------------
// WEIGHTS
// -----------------------------------------------------------------------------

// Distances above this weigh exp(-max_distance) (1.7e-38, a normal float).
constexpr float max_distance = 87;

// exp(-d) for d in [0, max_distance] to about 1e-7 relative: a branch-free
// polynomial the compiler vectorises, where std::exp is a call per element.
// 2^t = 2^i 2^(f + 1/2) / sqrt(2), i = trunc(t), f in (-1, 0].
inline float exp_negative(float d) {
  auto t = d * -1.44269504f;
  auto i = (int32_t)t;
  auto g = (t - (float)i + 0.5f) * 0.693147181f;  // |g| <= ln(2) / 2
  auto poly =
      1 +
      g * (1 + g * (0.5f +
                       g * (1.0f / 6 +
                               g * (1.0f / 24 +
                                       g * (1.0f / 120 + g * (1.0f / 720))))));
  auto bits = (int32_t)((i + 127) * (1 << 23));
  return poly * __builtin_bit_cast(float, bits) * 0.707106781f;
}

// The colour the weights compare, with the variance of its values relative
// to the variance of the full mean (2 for a half buffer).
struct weight_guide {
  const padded_color* color          = nullptr;
  float               variance_scale = 1;
};

// NL-means distance of one channel: the squared difference less its
// expected variance, in units of var_a + var_b (Rousselle et al. 2012; the
// min makes a pixel whose own variance is high less picky). A run of
// strength k divides it by k^2 (run_set).
inline float nlm_distance(float diff, float a, float b, float eps) {
  return (diff * diff - (a + std::min(a, b))) / (eps + (a + b));
}

// Welch's t statistic squared less the threshold squared: positive when the
// test tells the means of one channel apart.
inline float welch_excess(float diff, float a, float b, float eps, float t2) {
  return diff * diff - t2 * (a + b) - eps;
}

// Colour distances of pixels (x, ya) and (x + dx, yb) for x in [-patch,
// width + patch): the NL-means distance averaged over channels, or for the
// t-test 0 when Welch's test keeps b and 1e30 when it rejects b. Pairs with
// a missing pixel: 0. One statement per channel: the loops vectorise.
IMPLICIT_WIDE_LOOPS void color_distances(const guide_data& guide,
    const weight_guide& source, const denoise_params& params, int ya, int yb,
    int dx, int patch, float* distances) {
  auto& color = *source.color;
  auto& var   = guide.variance_planes;
  auto  s     = source.variance_scale;
  auto  eps   = guide.epsilon;
  auto  a0 = color[0].row(ya), a1 = color[1].row(ya), a2 = color[2].row(ya);
  auto  b0 = color[0].row(yb) + dx, b1 = color[1].row(yb) + dx,
       b2  = color[2].row(yb) + dx;
  auto va0 = var[0].row(ya), va1 = var[1].row(ya), va2 = var[2].row(ya);
  auto vb0 = var[0].row(yb) + dx, vb1 = var[1].row(yb) + dx,
       vb2 = var[2].row(yb) + dx;
  auto ma = guide.valid_plane.row(ya), mb = guide.valid_plane.row(yb) + dx;
  auto end = guide.width + patch;
  auto out = distances + patch;
  if (params.method == denoise_method::ttest) {
    auto t2 = params.ttest_threshold * params.ttest_threshold * s;
    for (auto x = -patch; x < end; x++) {
      auto e0     = welch_excess(a0[x] - b0[x], va0[x], vb0[x], eps, t2);
      auto e1     = welch_excess(a1[x] - b1[x], va1[x], vb1[x], eps, t2);
      auto e2     = welch_excess(a2[x] - b2[x], va2[x], vb2[x], eps, t2);
      auto excess = std::max(e0, std::max(e1, e2));
      out[x]      = (excess > 0 ? 1e30f : 0.0f) * ma[x] * mb[x];
    }
    return;
  }
  for (auto x = -patch; x < end; x++) {
    auto d0 = nlm_distance(a0[x] - b0[x], va0[x] * s, vb0[x] * s, eps);
    auto d1 = nlm_distance(a1[x] - b1[x], va1[x] * s, vb1[x] * s, eps);
    auto d2 = nlm_distance(a2[x] - b2[x], va2[x] * s, vb2[x] * s, eps);
    out[x]  = (d0 + d1 + d2) * (1.0f / 3) * ma[x] * mb[x];
  }
}

// Add the squared feature distances of pixels (x, y) and (x + dx, y + dy)
// to distance[x] for x in [x0, x1); log depth relative to the plane through
// (x, y) (its gradient), so that slanted surfaces are one surface.
IMPLICIT_WIDE_LOOPS void add_feature_distances(const guide_data& guide, int y,
    int dx, int dy, int x0, int x1, float* distance) {
  auto plain = guide.has_depth ? guide.nfeatures - 1 : guide.nfeatures;
  for (auto k = 0; k < plain; k++) {
    auto fp = guide.feature_planes[k].row(y);
    auto fq = guide.feature_planes[k].row(y + dy) + dx;
    for (auto x = x0; x < x1; x++)
      distance[x] += (fq[x] - fp[x]) * (fq[x] - fp[x]);
  }
  if (!guide.has_depth) return;
  auto zp = guide.feature_planes[plain].row(y);
  auto zq = guide.feature_planes[plain].row(y + dy) + dx;
  auto gx = guide.gradient_x.row(y), gy = guide.gradient_y.row(y);
  for (auto x = x0; x < x1; x++) {
    auto d = zq[x] - zp[x] - (gx[x] * dx + gy[x] * dy);
    distance[x] += d * d;
  }
}

// The runs that one pass over the weights serves: each window radius times
// each NL-means strength, run (window w, strength s) at index
// w * strengths + s. A neighbour at offset (dx, dy) counts in window w when
// |dx| and |dy| are at most radii[w]. The weights of every run are functions
// of the same distances, so extra runs cost their exponentials and sums only.
struct run_set {
  int   radii[2]  = {};
  int   windows   = 1;
  float inv_k2[2] = {1, 1};  // 1 / k^2 of each strength
  int   strengths = 1;

  int  count() const { return windows * strengths; }
  int  radius() const { return std::max(radii[0], radii[windows - 1]); }
  bool in_window(int run, int dx, int dy) const {
    auto r = radii[run / strengths];
    return std::abs(dx) <= r && std::abs(dy) <= r;
  }
};

// The runs of the parameters: params.radius and params.select_radius, and
// for NL-means weights params.strength, and params.low_strength for nlm (the
// regression's runs cost 60 moments each: a second strength made nfor 0-9%
// better at 1.8x its time, README).
run_set make_run_set(const denoise_params& params) {
  auto runs     = run_set{};
  runs.radii[0] = params.radius;
  if (params.select_radius != 0 && params.select_radius != params.radius)
    runs.radii[runs.windows++] = params.select_radius;
  if (params.method == denoise_method::ttest) return runs;
  runs.inv_k2[0] = 1 / (params.strength * params.strength);
  if (params.method == denoise_method::nlm && params.low_strength > 0 &&
      params.low_strength != params.strength)
    runs.inv_k2[runs.strengths++] =
        1 / (params.low_strength * params.low_strength);
  return runs;
}

// sums[x] = pixel[x] + ... + pixel[x + 2 patch]: a row's patch sums.
IMPLICIT_WIDE_LOOPS void patch_row_sums(
    const float* pixel, int width, int patch, float* sums) {
  for (auto x = 0; x < width; x++) sums[x] = pixel[x];
  for (auto k = 1; k <= 2 * patch; k++)
    for (auto x = 0; x < width; x++) sums[x] += pixel[x + k];
}

// colour[x] for x in [x0, x1): the mean of the 2 patch + 1 rows of patch
// sums from `sums` (rows of `width`), at least 0.
IMPLICIT_WIDE_LOOPS void patch_column_sums(const float* sums, int width,
    int patch, int x0, int x1, float area, float* colour) {
  for (auto x = x0; x < x1; x++) colour[x] = sums[x];
  for (auto k = 1; k <= 2 * patch; k++)
    for (auto x = x0; x < x1; x++) colour[x] += sums[k * width + x];
  for (auto x = x0; x < x1; x++) colour[x] = std::max(colour[x] * area, 0.0f);
}

// The weights w[x] for x in [x0, x1) of pixel (x + dx, y + dy) for pixel
// (x, y) from their colour and feature distances, 0 for a missing one.
IMPLICIT_WIDE_LOOPS void distance_weights(const guide_data& guide, int y,
    int dx, int dy, int x0, int x1, float inv_k2, const float* colour,
    const float* features, float* w) {
  auto valid = guide.valid_plane.row(y + dy) + dx;
  auto trust = guide.trust.row(y);
  // Clamped in a loop of its own: a min beside the exponential stops GCC
  // from vectorising.
  for (auto x = x0; x < x1; x++)
    w[x] = std::min(colour[x] * inv_k2 + features[x] * trust[x], max_distance);
  for (auto x = x0; x < x1; x++) w[x] = exp_negative(w[x]) * valid[x];
}

// Calls visit(y, dx, dy, weights) for every row y of [y0, y1) and every
// offset (dx, dy) of the widest window, in a fixed order; weights[s][x] is
// the weight with strength s of pixel (x + dx, y + dy) for pixel (x, y), 0
// outside the image and for missing pixels. Patch distances are box sums of
// pixel distances, each a direct sum (no running sums, whose rounding would
// depend on where a block starts).
template <typename Visit>
void visit_weights(const guide_data& guide, const weight_guide& source,
    const denoise_params& params, const run_set& runs, int y0, int y1,
    Visit&& visit) {
  auto   width = guide.width, height = guide.height, radius = runs.radius();
  auto   patch      = params.method == denoise_method::ttest
                          ? 0
                          : std::max(params.patch_radius, 0);
  auto   rows       = y1 - y0 + 2 * patch;
  auto   area       = 1.0f / (float)((2 * patch + 1) * (2 * patch + 1));
  auto   pixel      = std::vector<float>((size_t)width + 2 * patch);
  auto   row_sums   = std::vector<float>((size_t)rows * width);
  auto   colour     = std::vector<float>(width);
  auto   features   = std::vector<float>(width);
  auto   weights    = std::vector<float>((size_t)runs.strengths * width);
  float* rows_of[2] = {weights.data(), weights.data() + width};
  for (auto dy = -radius; dy <= radius; dy++) {
    for (auto dx = -radius; dx <= radius; dx++) {
      for (auto row = 0; row < rows; row++) {
        auto ya = y0 - patch + row;
        color_distances(
            guide, source, params, ya, ya + dy, dx, patch, pixel.data());
        patch_row_sums(
            pixel.data(), width, patch, &row_sums[(size_t)row * width]);
      }
      auto x0 = std::max(0, -dx), x1 = std::min(width, width - dx);
      for (auto y = y0; y < y1; y++) {
        if (y + dy < 0 || y + dy >= height) continue;
        patch_column_sums(&row_sums[(size_t)(y - y0) * width], width, patch, x0,
            x1, area, colour.data());
        std::fill(features.begin(), features.end(), 0.0f);
        add_feature_distances(guide, y, dx, dy, x0, x1, features.data());
        std::fill(weights.begin(), weights.end(), 0.0f);
        for (auto s = 0; s < runs.strengths; s++)
          distance_weights(guide, y, dx, dy, x0, x1, runs.inv_k2[s],
              colour.data(), features.data(), rows_of[s]);
        visit(y, dx, dy, (const float* const*)rows_of);
      }
    }
  }
}

// -----------------------------------------------------------------------------
// FILTERS
// -----------------------------------------------------------------------------

// A filtered image and per pixel the derivative of its output by its own
// input, the weights taken as fixed: 1 / (sum of the weights), the pixel's
// own weight being 1 (for SURE, see select_by_sure).
struct filtered_image {
  std::vector<vec3f> color = {};
  std::vector<float> self  = {};
};

// Filtered images, one per run.
using filtered_runs = std::vector<filtered_image>;

// One zeroed filtered image per run.
filtered_runs make_filtered_runs(const run_set& runs, size_t pixels) {
  return filtered_runs(runs.count(),
      filtered_image{std::vector<vec3f>(pixels), std::vector<float>(pixels)});
}

// Add the weights w (a row of `width`) to sums[x] and the weighted
// differences of the three channels to the rows `count` and 2 and 3 times
// `count` after it.
IMPLICIT_WIDE_LOOPS void add_weighted_differences(
    const float* w, const float* diffs, int width, size_t count, float* sums) {
  for (auto x = 0; x < width; x++) sums[x] += w[x];
  for (auto c = 0; c < 3; c++) {
    auto s = sums + (c + 1) * count;
    auto d = diffs + (size_t)c * width;
    for (auto x = 0; x < width; x++) s[x] += w[x] * d[x];
  }
}

// Weighted mean of the neighbours of `values` with the weights of `source`,
// per run: the pixel's own value plus the mean of the differences, so a
// constant image stays exactly constant.
filtered_runs filter_mean(const guide_data& guide,
    const std::vector<vec3f>& values, const padded_color& planes,
    const weight_guide& source, const denoise_params& params,
    const run_set& runs) {
  auto width  = guide.width;
  auto output = make_filtered_runs(runs, values.size());
  auto blocks = (guide.height + block_rows - 1) / block_rows;
  tbb::parallel_for(0, blocks, [&](int block) {
    auto y0    = block * block_rows;
    auto y1    = std::min(y0 + block_rows, guide.height);
    auto count = (size_t)(y1 - y0) * width;
    // Per run: the weight sum, then the weighted differences per channel.
    auto sums  = std::vector<float>(count * 4 * runs.count(), 0.0f);
    auto diffs = std::vector<float>((size_t)3 * width);
    visit_weights(guide, source, params, runs, y0, y1,
        [&](int y, int dx, int dy, const float* const* weights) {
          for (auto c = 0; c < 3; c++) {
            auto yp = planes[c].row(y), yq = planes[c].row(y + dy) + dx;
            auto d = &diffs[(size_t)c * width];
            for (auto x = 0; x < width; x++) d[x] = yq[x] - yp[x];
          }
          for (auto run = 0; run < runs.count(); run++) {
            if (!runs.in_window(run, dx, dy)) continue;
            add_weighted_differences(weights[run % runs.strengths],
                diffs.data(), width, count,
                &sums[(size_t)run * 4 * count + (size_t)(y - y0) * width]);
          }
        });
    for (auto run = 0; run < runs.count(); run++) {
      auto  run_sums = &sums[(size_t)run * 4 * count];
      auto& out      = output[run];
      for (size_t local = 0; local < count; local++) {
        auto p = (size_t)y0 * width + local;
        auto w = run_sums[local];
        auto s = vec3f{run_sums[count + local], run_sums[2 * count + local],
            run_sums[3 * count + local]};
        out.color[p] = w > 0 ? values[p] + s / w : values[p];
        out.self[p]  = w > 0 ? 1 / w : 1;
      }
    }
  });
  return output;
}

// Solve the symmetric positive definite system a x = b (n unknowns, m
// right-hand sides, row-major) by Cholesky in place; false when a is not
// positive definite.
bool solve_cholesky(double* a, double* b, int n, int m) {
  for (auto j = 0; j < n; j++) {
    auto d = a[j * n + j];
    for (auto k = 0; k < j; k++) d -= a[j * n + k] * a[j * n + k];
    if (!(d > 0)) return false;
    a[j * n + j] = std::sqrt(d);
    for (auto i = j + 1; i < n; i++) {
      auto s = a[i * n + j];
      for (auto k = 0; k < j; k++) s -= a[i * n + k] * a[j * n + k];
      a[i * n + j] = s / a[j * n + j];
    }
  }
  for (auto c = 0; c < m; c++) {
    for (auto i = 0; i < n; i++) {
      auto s = b[i * m + c];
      for (auto k = 0; k < i; k++) s -= a[i * n + k] * b[k * m + c];
      b[i * m + c] = s / a[i * n + i];
    }
    for (auto i = n - 1; i >= 0; i--) {
      auto s = b[i * m + c];
      for (auto k = i + 1; k < n; k++) s -= a[k * n + i] * b[k * m + c];
      b[i * m + c] = s / a[i * n + i];
    }
  }
  return true;
}

// Moments of a weighted first-order regression per pixel, each a plane of
// the block: w, w x (nf), w y (3), w x x^T (upper triangle), w x y^T
// (nf x 3); x are the neighbour's features less the pixel's, y its value
// less the pixel's.
struct regression_layout {
  int features = 0, mean_x = 1, mean_y = 0, xx = 0, xy = 0, moments = 0;
};

// The layout for nf features.
regression_layout make_regression_layout(int nf) {
  auto layout     = regression_layout{};
  layout.features = nf;
  layout.mean_y   = 1 + nf;
  layout.xx       = layout.mean_y + 3;
  layout.xy       = layout.xx + nf * (nf + 1) / 2;
  layout.moments  = layout.xy + nf * 3;
  return layout;
}

// The regression's value at the pixel (features x = 0), relative to the
// pixel's own value: the weighted mean of y less the slopes times the mean
// of x; slopes by ridge regression on centred moments. m[j * stride] is
// moment j.
vec3f solve_regression(const regression_layout& layout, const float* m,
    size_t stride, float ridge) {
  auto nf = layout.features;
  auto sw = (double)m[0];
  if (!(sw > 0)) return {0, 0, 0};
  double mean_x[max_features], mean_y[3];
  for (auto k = 0; k < nf; k++)
    mean_x[k] = m[(layout.mean_x + k) * stride] / sw;
  for (auto c = 0; c < 3; c++) mean_y[c] = m[(layout.mean_y + c) * stride] / sw;
  double a[max_features * max_features], b[max_features * 3];
  auto   j = layout.xx;
  for (auto k = 0; k < nf; k++)
    for (auto l = k; l < nf; l++) {
      auto v =
          m[j++ * stride] / sw - mean_x[k] * mean_x[l] + (k == l ? ridge : 0);
      a[k * nf + l] = a[l * nf + k] = v;
    }
  for (auto k = 0; k < nf; k++)
    for (auto c = 0; c < 3; c++)
      b[k * 3 + c] = m[j++ * stride] / sw - mean_x[k] * mean_y[c];
  auto value = vec3f{(float)mean_y[0], (float)mean_y[1], (float)mean_y[2]};
  if (nf == 0 || !solve_cholesky(a, b, nf, 3)) return value;
  for (auto c = 0; c < 3; c++) {
    auto v = mean_y[c];
    for (auto k = 0; k < nf; k++) v -= b[k * 3 + c] * mean_x[k];
    at(value, c) = (float)v;
  }
  return value;
}

// The differences of one row of neighbours at offset (dx, dy) to their
// pixels: x (nf rows of scratch) then y (3 rows).
IMPLICIT_WIDE_LOOPS void regression_differences(const guide_data& guide,
    const regression_layout& layout, const padded_color& planes, int y, int dx,
    int dy, float* scratch) {
  auto width = guide.width, nf = layout.features;
  for (auto k = 0; k < nf; k++) {
    auto fp = guide.feature_planes[k].row(y);
    auto fq = guide.feature_planes[k].row(y + dy) + dx;
    for (auto x = 0; x < width; x++) scratch[k * width + x] = fq[x] - fp[x];
  }
  for (auto c = 0; c < 3; c++) {
    auto yp = planes[c].row(y), yq = planes[c].row(y + dy) + dx;
    auto out = &scratch[(nf + c) * width];
    for (auto x = 0; x < width; x++) out[x] = yq[x] - yp[x];
  }
}

// Add one row of neighbours, their differences in `scratch`
// (regression_differences) and weights w, to the moments.
IMPLICIT_WIDE_LOOPS void add_regression_row(const regression_layout& layout,
    int width, const float* scratch, const float* w, float* moments,
    size_t stride) {
  auto nf  = layout.features;
  auto add = [&](int j, const float* u) {
    auto m = moments + j * stride;
    for (auto x = 0; x < width; x++) m[x] += w[x] * u[x];
  };
  auto add2 = [&](int j, const float* u, const float* v) {
    auto m = moments + j * stride;
    for (auto x = 0; x < width; x++) m[x] += w[x] * u[x] * v[x];
  };
  for (auto x = 0; x < width; x++) moments[x] += w[x];
  for (auto k = 0; k < nf; k++) add(layout.mean_x + k, &scratch[k * width]);
  for (auto c = 0; c < 3; c++)
    add(layout.mean_y + c, &scratch[(nf + c) * width]);
  auto j = layout.xx;
  for (auto k = 0; k < nf; k++)
    for (auto l = k; l < nf; l++)
      add2(j++, &scratch[k * width], &scratch[l * width]);
  for (auto k = 0; k < nf; k++)
    for (auto c = 0; c < 3; c++)
      add2(j++, &scratch[k * width], &scratch[(nf + c) * width]);
}

// First-order regression of `values` on the features in each pixel's
// window, weighted by `source` (NFOR, Bitterli et al. 2016): features that
// vary with the image (shading normals, albedo, depth) explain the variation
// instead of blurring it.
filtered_runs filter_regression(const guide_data& guide,
    const std::vector<vec3f>& values, const padded_color& planes,
    const weight_guide& source, const denoise_params& params,
    const run_set& runs) {
  auto width  = guide.width;
  auto layout = make_regression_layout(guide.nfeatures);
  auto output = make_filtered_runs(runs, values.size());
  auto blocks = (guide.height + block_rows - 1) / block_rows;
  tbb::parallel_for(0, blocks, [&](int block) {
    auto y0      = block * block_rows;
    auto y1      = std::min(y0 + block_rows, guide.height);
    auto count   = (size_t)(y1 - y0) * width;
    auto size    = count * layout.moments;  // floats per run
    auto moments = std::vector<float>(size * runs.count(), 0.0f);
    auto scratch = std::vector<float>((size_t)(layout.features + 3) * width);
    visit_weights(guide, source, params, runs, y0, y1,
        [&](int y, int dx, int dy, const float* const* weights) {
          regression_differences(
              guide, layout, planes, y, dx, dy, scratch.data());
          for (auto run = 0; run < runs.count(); run++)
            if (runs.in_window(run, dx, dy))
              add_regression_row(layout, width, scratch.data(),
                  weights[run % runs.strengths],
                  &moments[run * size + (size_t)(y - y0) * width], count);
        });
    for (auto run = 0; run < runs.count(); run++) {
      auto m = &moments[run * size];
      for (size_t local = 0; local < count; local++) {
        auto p               = (size_t)y0 * width + local;
        output[run].color[p] = values[p] + solve_regression(layout, &m[local],
                                               count, params.ridge);
        output[run].self[p]  = m[local] > 0 ? 1 / m[local] : 1;
      }
    }
  });
  return output;
}

// The filter of a method.
filtered_runs filter_values(const guide_data& guide,
    const std::vector<vec3f>& values, const padded_color& planes,
    const weight_guide& source, const denoise_params& params,
    const run_set& runs) {
  switch (params.method) {
    case denoise_method::nfor:
      return filter_regression(guide, values, planes, source, params, runs);
    case denoise_method::nlm:
    case denoise_method::ttest:
      return filter_mean(guide, values, planes, source, params, runs);
  }
  return {};
}

// Every run of the method: cross filtering of the halves when there are
// halves (each half filtered with the weights of the other, so that no
// weight is correlated with the noise it averages), else the colour with its
// own weights (always for the t-test, which compares the pixels' own
// statistics).
filtered_runs run_filters(const guide_data& guide, const denoise_params& params,
    const run_set& runs) {
  auto cross = !guide.half_a.empty() && params.method != denoise_method::ttest;
  if (!cross)
    return filter_values(guide, guide.color, guide.color_planes,
        {&guide.color_planes, 1}, params, runs);
  auto a = filter_values(guide, guide.half_a, guide.half_a_planes,
      {&guide.half_b_planes, 2}, params, runs);
  auto b = filter_values(guide, guide.half_b, guide.half_b_planes,
      {&guide.half_a_planes, 2}, params, runs);
  for (size_t run = 0; run < a.size(); run++)
    for (size_t i = 0; i < a[run].color.size(); i++) {
      a[run].color[i] = (a[run].color[i] + b[run].color[i]) * 0.5f;
      a[run].self[i]  = (a[run].self[i] + b[run].self[i]) * 0.5f;
    }
  return a;
}

// Stein's unbiased risk estimate of a filtered image per pixel, summed over
// channels: (F - c)^2 - var + 2 var dF/dc, then averaged over the valid
// pixels of a (2 r + 1)^2 box (one pixel's estimate is very noisy).
std::vector<float> smoothed_sure(
    const guide_data& guide, const filtered_image& filtered, int r) {
  auto width = guide.width, height = guide.height;
  auto sure = std::vector<float>(filtered.color.size(), 0.0f);
  for (size_t i = 0; i < sure.size(); i++) {
    if (!guide.valid[i]) continue;
    auto d = filtered.color[i] - guide.color[i];
    auto risk =
        d * d - guide.variance[i] + 2 * guide.variance[i] * filtered.self[i];
    // The risk of the colour, not of the demodulated values.
    sure[i] = guide.scale.empty() ? sum(risk)
                                  : sum(risk * guide.scale[i] * guide.scale[i]);
  }
  auto smooth = std::vector<float>(sure.size(), 0.0f);
  tbb::parallel_for(0, height, [&](int y) {
    for (auto x = 0; x < width; x++) {
      auto total = 0.0f;
      auto n     = 0;
      for (auto j = std::max(y - r, 0); j <= std::min(y + r, height - 1); j++)
        for (auto i = std::max(x - r, 0); i <= std::min(x + r, width - 1);
             i++) {
          auto q = (size_t)j * width + i;
          if (guide.valid[q]) total += sure[q], n++;
        }
      smooth[(size_t)y * width + x] = n ? total / n : 0.0f;
    }
  });
  return smooth;
}

// Per pixel, the run whose smoothed SURE is lowest (Rousselle et al.,
// "Adaptive Rendering with Non-Local Means Filtering", 2012), the first of
// equal ones: a wide window where it averages away noise, a narrow one where
// the wide one blurs (edges, curved shading), a low strength where colours
// that differ within the noise still differ (glossy highlights); blended
// over the picks around, so that the choice does not switch pixel by pixel
// where two runs' estimates are close (Rousselle et al. filter their
// selection map for the same reason).
std::vector<vec3f> select_by_sure(const guide_data& guide,
    const filtered_runs& runs, const denoise_params& params) {
  if (runs.size() == 1) return runs[0].color;
  auto sures = std::vector<std::vector<float>>{};
  for (auto& run : runs)
    sures.push_back(smoothed_sure(guide, run, sure_radius));
  auto best = std::vector<int>(runs[0].color.size(), 0);
  for (size_t i = 0; i < best.size(); i++)
    for (size_t run = 1; run < runs.size(); run++)
      if (sures[run][i] < sures[best[i]][i]) best[i] = (int)run;
  // Each run weighs the share of the pixels around that pick it: the pixel's
  // own pick plus the mean difference, so a constant stays exact.
  auto width = guide.width, height = guide.height,
       r      = std::max(params.blend_radius, 0);
  auto output = std::vector<vec3f>(best.size());
  tbb::parallel_for(0, height, [&](int y) {
    for (auto x = 0; x < width; x++) {
      auto p    = (size_t)y * width + x;
      auto own  = runs[best[p]].color[p];
      auto diff = vec3f{0, 0, 0};
      auto n    = 0;
      for (auto j = std::max(y - r, 0); j <= std::min(y + r, height - 1); j++)
        for (auto i = std::max(x - r, 0); i <= std::min(x + r, width - 1);
             i++, n++)
          diff += runs[best[(size_t)j * width + i]].color[p] - own;
      output[p] = own + diff / (float)n;
    }
  });
  return output;
}

}  // namespace

// -----------------------------------------------------------------------------
// DENOISING
// -----------------------------------------------------------------------------

// Every run of the method (run_set), and per pixel the best.
std::vector<vec3f> denoise_image(
    const denoise_buffers& buffers, const denoise_params& params) {
  check_buffers(buffers);
  if (buffers.width == 0 || buffers.height == 0) return {};
  if (params.radius < 0 || params.patch_radius < 0 ||
      params.select_radius < 0 || params.blend_radius < 0)
    throw std::invalid_argument("denoise_image: negative radius");
  if (!(params.strength > 0) || !(params.low_strength >= 0))
    throw std::invalid_argument(
        "denoise_image: strength must be positive, low_strength at least 0");
  if (!(params.demodulate >= 0) || !std::isfinite(params.demodulate) ||
      !(params.outlier_ratio >= 0))
    throw std::invalid_argument(
        "denoise_image: demodulate and outlier_ratio must be at least 0");
  auto runs  = make_run_set(params);
  auto guide = make_guide(
      buffers, params, runs.radius(), std::max(params.patch_radius, 0));
  auto denoised =
      select_by_sure(guide, run_filters(guide, params, runs), params);
  // The filter's change, modulated again: a constant stays exactly constant.
  if (!guide.scale.empty())
    for (size_t i = 0; i < denoised.size(); i++)
      denoised[i] =
          guide.modulated[i] + (denoised[i] - guide.color[i]) * guide.scale[i];
  return denoised;
}

// Parse a method name.
denoise_method parse_denoise_method(const std::string& name) {
  for (size_t i = 0; i < denoise_method_names.size(); i++)
    if (denoise_method_names[i] == name) return (denoise_method)i;
  auto names = std::string{};
  for (auto& known : denoise_method_names)
    names += (names.empty() ? "" : ", ") + known;
  throw std::invalid_argument(
      "unknown denoise method \"" + name + "\" (expected " + names + ")");
}

}  // namespace implicit
