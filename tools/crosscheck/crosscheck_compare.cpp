// # implicit crosscheck: per-region comparison of two renderers
//
// Reads a region mask (8-bit PGM, 0 = not counted, k = region k, names in a
// text file, one per line) and two sets of independent renders of the same
// scene (ours and a reference, any format load_image reads, e.g. EXR), and
// prints, per region, the mean colour of each, their relative difference
// and its Monte Carlo standard error. The standard error comes from the
// spread of the per-batch region means (batches are renders with different
// seeds), so it needs at least 2 renders per side. Optionally writes a
// side-by-side PNG: ours | reference | |difference| x 4.
//
// Usage:
//   crosscheck_compare --mask regions.pgm --names regions.txt --case NAME
//       --ours ours_0.exr ours_1.exr ... --ref cycles_0.exr ...
//       [--png side_by_side.png]
//   crosscheck_compare stack --output montage.png a.png b.png ...
//   crosscheck_compare relmse --ref reference.exr a.exr b.exr ...
// (the second stacks images of the same width top to bottom, for the
// README's montage of side-by-side images; the third prints the relative
// MSE of each image against a reference, mean over pixels and channels of
// (x - ref)^2 / (ref^2 + 0.01), as bench/bench_lights.cpp, then their mean).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "image/image.h"
#include "image/image_io.h"
#include "util/error.h"

using namespace implicit;

// -----------------------------------------------------------------------------
// INPUT
// -----------------------------------------------------------------------------

// Region mask as read from a binary 8-bit PGM (P5, maxval 255).
struct region_mask {
  int                  width  = 0;
  int                  height = 0;
  std::vector<uint8_t> ids    = {};
};

// Load a P5 PGM without comments (as make_scenes.py writes it).
static region_mask load_mask(const std::string& filename) {
  auto stream = std::ifstream(filename, std::ios::binary);
  if (!stream) throw_io_error(filename, "cannot open file");
  auto magic  = std::string{};
  auto mask   = region_mask{};
  auto maxval = 0;
  stream >> magic >> mask.width >> mask.height >> maxval;
  if (!stream || magic != "P5" || maxval != 255 || mask.width <= 0 ||
      mask.height <= 0)
    throw_io_error(filename, "header: expected 'P5 width height 255'");
  stream.get();  // the single whitespace after maxval
  mask.ids.resize((size_t)mask.width * mask.height);
  stream.read((char*)mask.ids.data(), (std::streamsize)mask.ids.size());
  if (stream.gcount() != (std::streamsize)mask.ids.size())
    throw_io_error(filename, "pixels: file is truncated");
  return mask;
}

// One name per line; empty lines are skipped.
static std::vector<std::string> load_names(const std::string& filename) {
  auto stream = std::ifstream(filename);
  if (!stream) throw_io_error(filename, "cannot open file");
  auto names = std::vector<std::string>{};
  for (auto line = std::string{}; std::getline(stream, line);)
    if (!line.empty()) names.push_back(line);
  return names;
}

// -----------------------------------------------------------------------------
// STATISTICS
// -----------------------------------------------------------------------------

// Mean and standard error of the mean of each region over a set of renders,
// per channel: R, G, B and their average (index 3).
struct region_stats {
  std::vector<std::array<double, 4>> mean    = {};
  std::vector<std::array<double, 4>> stderr_ = {};
  std::vector<int>                   pixels  = {};
};

// Region means of each render, then their average and its standard error
// (sample standard deviation of the batch means / sqrt(batches)).
static region_stats compute_stats(const std::vector<image_data>& images,
    const region_mask& mask, int regions) {
  auto batches = (int)images.size();
  // batch_means[b][r][c]; c = 3 is the channel average.
  auto batch_means = std::vector<std::vector<std::array<double, 4>>>(
      batches, std::vector<std::array<double, 4>>(regions, {0, 0, 0, 0}));
  auto stats   = region_stats{};
  stats.pixels = std::vector<int>(regions, 0);
  for (auto idx = size_t{0}; idx < mask.ids.size(); idx++) {
    auto r = (int)mask.ids[idx] - 1;
    if (r >= 0 && r < regions) stats.pixels[r] += 1;
  }
  for (auto b = 0; b < batches; b++) {
    for (auto idx = size_t{0}; idx < mask.ids.size(); idx++) {
      auto r = (int)mask.ids[idx] - 1;
      if (r < 0 || r >= regions) continue;
      auto& p = images[b].pixels[idx];
      auto& m = batch_means[b][r];
      m[0] += p.x, m[1] += p.y, m[2] += p.z, m[3] += (p.x + p.y + p.z) / 3;
    }
    for (auto r = 0; r < regions; r++)
      for (auto& v : batch_means[b][r]) v /= std::max(stats.pixels[r], 1);
  }
  for (auto r = 0; r < regions; r++) {
    auto mean = std::array<double, 4>{0, 0, 0, 0};
    auto var  = std::array<double, 4>{0, 0, 0, 0};
    for (auto b = 0; b < batches; b++)
      for (auto c = 0; c < 4; c++) mean[c] += batch_means[b][r][c] / batches;
    for (auto b = 0; b < batches; b++)
      for (auto c = 0; c < 4; c++) {
        auto d = batch_means[b][r][c] - mean[c];
        var[c] += d * d / (batches - 1);
      }
    auto se = std::array<double, 4>{};
    for (auto c = 0; c < 4; c++) se[c] = std::sqrt(var[c] / batches);
    stats.mean.push_back(mean);
    stats.stderr_.push_back(se);
  }
  return stats;
}

// Relative difference a / b - 1 of channel c in region r, and its standard
// error from both sides' (first-order error propagation).
static std::pair<double, double> relative_difference(
    const region_stats& a, const region_stats& b, int r, int c) {
  auto ma = a.mean[r][c], mb = b.mean[r][c];
  auto se = std::sqrt(std::pow(a.stderr_[r][c] / mb, 2) +
                      std::pow(ma * b.stderr_[r][c] / (mb * mb), 2));
  return {ma / mb - 1, se};
}

// Average of a set of renders of the same size.
static image_data average_images(const std::vector<image_data>& images) {
  auto result = make_image(images[0].width, images[0].height);
  for (auto& image : images)
    for (auto idx = size_t{0}; idx < image.pixels.size(); idx++)
      result.pixels[idx] += image.pixels[idx] * (1.0f / images.size());
  return result;
}

// -----------------------------------------------------------------------------
// MAIN
// -----------------------------------------------------------------------------

// Load renders and check that they match the mask's size.
static std::vector<image_data> load_renders(
    const std::vector<std::string>& filenames, const region_mask& mask) {
  auto images = std::vector<image_data>{};
  for (auto& filename : filenames) {
    images.push_back(load_image(filename));
    if (images.back().width != mask.width ||
        images.back().height != mask.height)
      throw_io_error(filename, "size " + std::to_string(images.back().width) +
                                   "x" + std::to_string(images.back().height) +
                                   " differs from the mask's " +
                                   std::to_string(mask.width) + "x" +
                                   std::to_string(mask.height));
  }
  return images;
}

// Side-by-side PNG: ours | reference | |ours - reference| x 4.
static void save_side_by_side(const std::string& filename,
    const image_data& ours, const image_data& ref) {
  auto w     = ours.width;
  auto image = make_image(3 * w, ours.height);
  for (auto j = 0; j < ours.height; j++) {
    for (auto i = 0; i < w; i++) {
      auto a = pixel(ours, i, j), b = pixel(ref, i, j);
      auto d                     = vec3f{a.x - b.x, a.y - b.y, a.z - b.z};
      pixel(image, i, j)         = {a.x, a.y, a.z, 1};
      pixel(image, w + i, j)     = {b.x, b.y, b.z, 1};
      pixel(image, 2 * w + i, j) = {
          4 * std::abs(d.x), 4 * std::abs(d.y), 4 * std::abs(d.z), 1};
    }
  }
  save_image(filename, image);
}

// Images of one width, top to bottom.
static image_data stack_images(const std::vector<std::string>& filenames) {
  auto images = std::vector<image_data>{};
  auto height = 0;
  for (auto& filename : filenames) {
    images.push_back(load_image(filename));
    if (images.back().width != images.front().width)
      throw_io_error(filename, "width " + std::to_string(images.back().width) +
                                   " differs from the first image's " +
                                   std::to_string(images.front().width));
    height += images.back().height;
  }
  auto stack = make_image(images.front().width, height);
  auto row   = 0;
  for (auto& image : images) {
    for (auto j = 0; j < image.height; j++)
      for (auto i = 0; i < image.width; i++)
        pixel(stack, i, row + j) = pixel(image, i, j);
    row += image.height;
  }
  return stack;
}

// Relative MSE of an image against a reference of the same size.
static double relative_mse(const image_data& image, const image_data& ref,
    const std::string& filename) {
  if (image.width != ref.width || image.height != ref.height)
    throw_io_error(filename, "size differs from the reference's");
  auto sum = 0.0;
  for (size_t k = 0; k < image.pixels.size(); k++) {
    for (auto c = 0; c < 3; c++) {
      auto x = (double)(&image.pixels[k].x)[c];
      auto r = (double)(&ref.pixels[k].x)[c];
      sum += (x - r) * (x - r) / (r * r + 0.01);
    }
  }
  return sum / (3.0 * image.pixels.size());
}

// relmse: each image's relative MSE against the reference, and the mean.
static void print_relative_mse(
    const std::string& ref_file, const std::vector<std::string>& files) {
  auto ref = load_image(ref_file);
  auto sum = 0.0;
  for (auto& filename : files) {
    auto error = relative_mse(load_image(filename), ref, filename);
    std::printf("%s %.6g\n", filename.c_str(), error);
    sum += error;
  }
  std::printf("mean %.6g\n", sum / files.size());
}

// The comparison: one markdown row per region. rel = ours / ref - 1 on the
// channel average; se = its standard error (both sides); z = rel / se;
// worst = the channel with the largest |relative difference|.
static void compare_regions(const std::string& mask_file,
    const std::string& names_file, const std::string& case_name,
    const std::vector<std::string>& ours_files,
    const std::vector<std::string>& ref_files, const std::string& png_file) {
  auto mask    = load_mask(mask_file);
  auto names   = load_names(names_file);
  auto ours    = load_renders(ours_files, mask);
  auto ref     = load_renders(ref_files, mask);
  auto regions = (int)names.size();
  auto a       = compute_stats(ours, mask, regions);
  auto b       = compute_stats(ref, mask, regions);
  for (auto r = 0; r < regions; r++) {
    auto [rel, se] = relative_difference(a, b, r, 3);
    auto worst = 0.0, worst_se = 0.0;
    for (auto c = 0; c < 3; c++) {
      auto [rc, sec] = relative_difference(a, b, r, c);
      if (std::abs(rc) > std::abs(worst)) worst = rc, worst_se = sec;
    }
    std::printf(
        "| %-16s | %-10s | %5d | %.4f %.4f %.4f | %.4f %.4f %.4f | "
        "%+6.2f%% | %5.2f%% | %+6.1f | %+6.2f%% ± %.2f%% |\n",
        case_name.c_str(), names[r].c_str(), a.pixels[r], a.mean[r][0],
        a.mean[r][1], a.mean[r][2], b.mean[r][0], b.mean[r][1], b.mean[r][2],
        100 * rel, 100 * se, se > 0 ? rel / se : 0.0, 100 * worst,
        100 * worst_se);
  }
  if (!png_file.empty())
    save_side_by_side(png_file, average_images(ours), average_images(ref));
}

int main(int argc, const char** argv) {
  auto mask_file  = std::string{};
  auto names_file = std::string{};
  auto case_name  = std::string{"case"};
  auto ours_files = std::vector<std::string>{};
  auto ref_files  = std::vector<std::string>{};
  auto png_file   = std::string{};
  auto app        = CLI::App{"Per-region mean colours of two renderers"};
  app.add_option("--mask", mask_file, "Region mask (P5 PGM)");
  app.add_option("--names", names_file, "Region names, one per line");
  app.add_option("--case", case_name, "Case name printed in the table");
  app.add_option("--ours", ours_files, "Our renders (>= 2 seeds)");
  app.add_option("--ref", ref_files, "Reference renders (>= 2 seeds)");
  app.add_option("--png", png_file, "Side-by-side PNG to write");
  auto stack_output = std::string{};
  auto stack_inputs = std::vector<std::string>{};
  auto stack        = app.add_subcommand("stack", "Stack images top to bottom");
  stack->add_option("--output", stack_output, "Image to write")->required();
  stack->add_option("images", stack_inputs, "Images of one width")->required();
  auto relmse_ref    = std::string{};
  auto relmse_inputs = std::vector<std::string>{};
  auto relmse =
      app.add_subcommand("relmse", "Relative MSE against a reference");
  relmse->add_option("--ref", relmse_ref, "Reference image")->required();
  relmse->add_option("images", relmse_inputs, "Images")->required();
  CLI11_PARSE(app, argc, argv);
  if (!relmse->parsed() && !stack->parsed()) {
    if (mask_file.empty() || names_file.empty()) {
      std::fprintf(stderr, "--mask and --names are required\n");
      return 1;
    }
    if (ours_files.size() < 2 || ref_files.size() < 2) {
      std::fprintf(
          stderr, "need at least 2 renders per side for a standard error\n");
      return 1;
    }
  }
  try {
    if (relmse->parsed()) {
      print_relative_mse(relmse_ref, relmse_inputs);
    } else if (stack->parsed()) {
      save_image(stack_output, stack_images(stack_inputs));
    } else {
      compare_regions(
          mask_file, names_file, case_name, ours_files, ref_files, png_file);
    }
  } catch (const io_error& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
  return 0;
}
