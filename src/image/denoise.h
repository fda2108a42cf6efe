// # implicit: denoising
//
// Filters a Monte Carlo render with its per-pixel statistics (variance, two
// half buffers of independent samples) and auxiliary features (albedo,
// normal, depth). A pure image function: the render core fills the buffers,
// this module knows nothing of scenes or rays. No trained weights.
//
// Methods (denoise_method):
// - nfor: first-order regression on the features in a window, weighted by
//   NL-means distances of the other half buffer (cross filtering), the two
//   filtered halves averaged (Bitterli et al., "Nonlinearly Weighted
//   First-Order Regression for Denoising Monte Carlo Renderings", EGSR 2016).
// - nlm: the same weights (NL-means on colour, Rousselle et al. 2012, times
//   feature weights as Rousselle et al. 2013), a weighted mean instead of a
//   regression.
// - ttest: a neighbour is averaged when Welch's t-test does not tell its mean
//   from the pixel's (Sakai et al., "A Statistical Approach to Monte Carlo
//   Denoising", SIGGRAPH Asia 2024), times the same feature weights.
//
// Every method filters the lighting: colour divided by albedo (plus a floor)
// when there is an albedo, multiplied back after (texture demodulation, as
// in Schied et al., "Spatiotemporal Variance-Guided Filtering", HPG 2017),
// and lets a firefly pixel average with neighbours its features set apart.
//
// Every method: deterministic (the same output at any thread count), a
// constant image (colour and albedo) stays constant, non-finite inputs are
// missing data (a pixel whose colour is NaN or inf is filled from its
// neighbours and never read by them), optional buffers may be empty.
#pragma once

#include <string>
#include <vector>

#include "../math/math.h"

namespace implicit {

// -----------------------------------------------------------------------------
// BUFFERS AND PARAMETERS
// -----------------------------------------------------------------------------

// What a render knows per pixel, row-major, row 0 at the top. Only width,
// height and one of color or (color_a and color_b) are required; every other
// buffer is empty or has width * height entries.
struct denoise_buffers {
  int                width    = 0;
  int                height   = 0;
  std::vector<vec3f> color    = {};  // mean radiance per pixel (linear)
  std::vector<vec3f> color_a  = {};  // mean of the even-numbered samples
  std::vector<vec3f> color_b  = {};  // mean of the odd-numbered samples
  std::vector<vec3f> variance = {};  // sample variance of the MEAN (var/n)
  std::vector<vec3f> albedo   = {};  // first non-specular hit albedo
  std::vector<vec3f> normal   = {};  // first non-specular hit normal (world)
  std::vector<float> depth    = {};  // camera distance (0 or inf: no hit)
  std::vector<int>   samples  = {};  // samples per pixel
};

// Denoising methods, see the top of this file.
enum class denoise_method { nfor, nlm, ttest };
inline const std::vector<std::string> denoise_method_names = {
    "nfor", "nlm", "ttest"};

// Options; the defaults are the measured best (README, Denoising).
struct denoise_params {
  denoise_method method       = denoise_method::nlm;
  int            radius       = 7;  // window of (2 radius + 1)^2 pixels
  int            patch_radius = 1;  // NL-means patch of (2 p + 1)^2 pixels
  // NL-means strength k: colour distances are in units of k^2 times the
  // variance of the difference (Rousselle et al. 2012).
  float strength = 1.0f;
  // A second, pickier strength for nlm (0: none): each window also runs
  // with it, and the per-pixel choice below picks among all runs.
  float low_strength = 0.5f;
  // The filters see colour / (albedo + demodulate), the lighting, and the
  // output is multiplied back (0: they see the colour).
  float demodulate = 0.05f;
  // A pixel whose variance is above outlier_ratio times the median of its
  // neighbours' (a firefly) weighs its feature distances less (0: never).
  float outlier_ratio = 4.0f;
  // Welch t-test: |mean_p - mean_q| <= threshold sqrt(var_p + var_q).
  float ttest_threshold = 2.0f;
  // Feature distances: a neighbour whose albedo differs by albedo_sigma
  // (or normal by normal_sigma, or depth by depth_sigma relative to the
  // plane through the pixel) weighs exp(-1) as much.
  float albedo_sigma = 0.1f;
  float normal_sigma = 0.25f;
  float depth_sigma  = 0.05f;
  // Regression (nfor): ridge on the slopes, relative to the weight sum.
  float ridge = 0.01f;
  // A second run with a window of this radius, and per pixel the run whose
  // error estimate (SURE) is lowest; 0 or radius: one window.
  int select_radius = 2;
  // The runs are blended by their shares of the picks over (2 blend_radius +
  // 1)^2 pixels (0: each pixel's own pick; README: relMSE 2-13% lower).
  int blend_radius = 3;
};

// -----------------------------------------------------------------------------
// DENOISING
// -----------------------------------------------------------------------------

// The denoised colour, width * height pixels. Throws std::invalid_argument
// when a non-empty buffer has the wrong size or no colour is given.
std::vector<vec3f> denoise_image(
    const denoise_buffers& buffers, const denoise_params& params = {});

// Parse a method name; throws std::invalid_argument listing the names.
denoise_method parse_denoise_method(const std::string& name);

}  // namespace implicit
