// End-to-end tests of issue 24's outputs: AOV layers in .exr files (read
// back with OpenEXR itself) and beside other formats, written by ypathtrace
// exactly as the render core averages them.

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "image/image_io.h"
#include "scene/scene_io.h"
#include "test_commands.h"
#include "trace/render.h"

namespace fs = std::filesystem;
using namespace implicit_test;
using namespace implicit;

namespace {

// The channel names of an OpenEXR file.
std::set<std::string> exr_channels(const std::string& filename) {
  auto file     = Imf::InputFile(filename.c_str());
  auto channels = std::set<std::string>{};
  for (auto it = file.header().channels().begin();
       it != file.header().channels().end(); ++it)
    channels.insert(it.name());
  return channels;
}

// One channel of an OpenEXR file as floats.
std::vector<float> exr_channel(
    const std::string& filename, const std::string& name) {
  auto file   = Imf::InputFile(filename.c_str());
  auto window = file.header().dataWindow();
  auto width  = window.max.x - window.min.x + 1;
  auto height = window.max.y - window.min.y + 1;
  auto values = std::vector<float>((size_t)width * height);
  auto buffer = Imf::FrameBuffer{};
  buffer.insert(name, Imf::Slice{Imf::FLOAT, (char*)values.data(),
                          sizeof(float), sizeof(float) * (size_t)width});
  file.setFrameBuffer(buffer);
  file.readPixels(window.min.y, window.max.y);
  return values;
}

// Channel `c` of a layer as a plane.
std::vector<float> layer_plane(const image_layer& layer, size_t c) {
  auto step   = layer.channels.size();
  auto values = std::vector<float>{};
  for (auto k = c; k < layer.values.size(); k += step)
    values.push_back(layer.values[k]);
  return values;
}

// ypathtrace on the example scene, writing `out`, with more options.
command_result render_example(
    const std::string& out, const std::string& options) {
  return run_command(program_path("ypathtrace") + " --scene " +
                     example_scene() + " --output " + out + " " + options);
}

bool same_floats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

}  // namespace

TEST_CASE("clean: --aov writes OpenEXR layers as the render core averages") {
  auto dir    = test_dir("clean_aov");
  auto out    = (dir / "out.exr").string();
  auto result = render_example(out,
      "--resolution 32 --samples 4 --quiet --aov "
      "depth,albedo,normal,position,variance");
  INFO(result.output);
  REQUIRE(result.status == 0);
  auto expected = std::set<std::string>{"R", "G", "B", "A", "albedo.R",
      "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z", "depth.Z",
      "position.X", "position.Y", "position.Z", "variance.R", "variance.G",
      "variance.B"};
  CHECK(exr_channels(out) == expected);

  // The same render in this process: the file holds its layers exactly.
  auto params       = trace_params{};
  params.resolution = 32;
  params.samples    = 4;
  params.aovs       = (1 << (int)aov_type_names.size()) - 1;
  auto context      = make_render_context(load_scene(example_scene()), params);
  auto warnings     = std::vector<std::string>{};
  params            = resolve_params(*context, params, "", warnings);
  auto state        = make_render_state(*context, params);
  REQUIRE(render_step(*context, state, params.samples));
  for (auto& layer : average_layers(state.buffer, params)) {
    for (size_t c = 0; c < layer.channels.size(); c++) {
      auto name = layer.name + "." + layer.channels[c];
      INFO(name);
      CHECK(same_floats(exr_channel(out, name), layer_plane(layer, c)));
    }
  }
  // The beauty channels are the image's.
  auto image = get_image(state);
  auto red   = std::vector<float>{};
  for (auto& pixel : image.pixels) red.push_back(pixel.x);
  CHECK(same_floats(exr_channel(out, "R"), red));
}

TEST_CASE("clean: beside a .png each layer is an .exr of its own") {
  auto dir    = test_dir("clean_aov_png");
  auto out    = (dir / "out.png").string();
  auto result = render_example(out,
      "--resolution 24 --samples 2 --quiet "
      "--aov normal,depth --savebatch 1");
  INFO(result.output);
  REQUIRE(result.status == 0);
  CHECK(fs::exists(out));
  CHECK(exr_channels((dir / "out.normal.exr").string()) ==
        std::set<std::string>{"X", "Y", "Z"});
  CHECK(exr_channels((dir / "out.depth.exr").string()) ==
        std::set<std::string>{"Z"});
  // They load back as images: the normal's X, Y and Z as R, G and B (an
  // average of unit vectors where a surface was hit), the depth as grey.
  auto normal = load_image((dir / "out.normal.exr").string());
  auto depth  = load_image((dir / "out.depth.exr").string());
  REQUIRE(normal.pixels.size() == depth.pixels.size());
  auto unit = 0, hits = 0;
  for (size_t i = 0; i < depth.pixels.size(); i++) {
    auto n = normal.pixels[i], d = depth.pixels[i];
    CHECK((d.x == d.y && d.y == d.z));
    if (d.x <= 0) continue;
    hits++;
    auto size = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    CHECK(size <= 1.001f);
    if (size > 0.999f) unit++;
  }
  CHECK(hits > 100);
  CHECK(unit > hits / 2);
  CHECK(!fs::exists(dir / "out.albedo.exr"));
  // Batch images get theirs too.
  CHECK(fs::exists(dir / "out-s0001.depth.exr"));
  // Only the finished files: no temporaries left.
  for (auto& entry : fs::directory_iterator(dir))
    CHECK(entry.path().filename().string()[0] != '.');
}

TEST_CASE("clean: --time stops after a pass and writes a valid image") {
  auto dir    = test_dir("clean_time");
  auto out    = (dir / "out.exr").string();
  auto result = render_example(out,
      "--resolution 48 --samples 1000000 --time 0.5 "
      "--aov variance --savebatch 100000");
  INFO(result.output);
  REQUIRE(result.status == 0);
  // It says where it stopped: a pass end (1, 2, 4, ... 64, then every 64).
  auto found = result.output.find("time budget");
  REQUIRE(found != std::string::npos);
  auto at      = result.output.find(" at ", found);
  auto samples = std::atoi(result.output.c_str() + at + 4);
  CHECK(samples >= 1);
  CHECK(samples < 1000000);
  CHECK((samples <= 64 ? (samples & (samples - 1)) == 0 : samples % 64 == 0));
  auto image = load_image(out);
  CHECK(image.width == 48);
  auto lit = 0;
  for (auto& pixel : image.pixels) {
    CHECK(std::isfinite(pixel.x + pixel.y + pixel.z + pixel.w));
    lit += pixel.x > 0;
  }
  CHECK(lit > (int)image.pixels.size() / 2);
  CHECK(exr_channels(out).count("variance.R") == 1);
  CHECK(!fs::exists(dir / "out-s100000.exr"));
}

TEST_CASE("clean: --denoise writes the denoiser's image of the render") {
  auto dir    = test_dir("clean_denoise");
  auto out    = (dir / "out.exr").string();
  auto result = render_example(out,
      "--resolution 40 --samples 6 --quiet "
      "--denoise --savebatch 4 --threads 2");
  INFO(result.output);
  REQUIRE(result.status == 0);
  // The same render here, its buffers handed to the denoiser.
  auto params       = trace_params{};
  params.resolution = 40;
  params.samples    = 6;
  params.denoise    = true;
  auto context      = make_render_context(load_scene(example_scene()), params);
  auto warnings     = std::vector<std::string>{};
  params            = resolve_params(*context, params, "", warnings);
  auto state        = make_render_state(*context, params);
  REQUIRE(render_step(*context, state, 4));
  auto buffers = make_denoise_buffers(state.buffer);
  // Half buffers: samples 0, 2 and 1, 3 average to the mean.
  for (size_t idx = 0; idx < buffers.color.size(); idx++) {
    auto mean = (buffers.color_a[idx] + buffers.color_b[idx]) * 0.5f;
    CHECK(length(mean - buffers.color[idx]) <=
          1e-5f * (1 + length(buffers.color[idx])));
  }
  auto batch    = load_image((dir / "out-s0004.exr").string());
  auto denoised = denoise_image(buffers);
  auto raw      = get_image(state);
  auto changed  = 0;
  for (size_t idx = 0; idx < denoised.size(); idx++) {
    CHECK(batch.pixels[idx].x == denoised[idx].x);
    CHECK(batch.pixels[idx].z == denoised[idx].z);
    CHECK(batch.pixels[idx].w == raw.pixels[idx].w);  // coverage as is
    changed += denoised[idx].x != raw.pixels[idx].x;
  }
  CHECK(changed > (int)denoised.size() / 2);
  REQUIRE(render_step(*context, state, 2));
  auto final = load_image(out);
  auto image = output_image(state.buffer, params);
  CHECK(std::memcmp(final.pixels.data(), image.pixels.data(),
            image.pixels.size() * sizeof(vec4f)) == 0);
  // --denoiser picks the method: NFOR's image of the same buffers.
  auto nfor_out = (dir / "nfor.exr").string();
  auto nfor     = render_example(nfor_out,
          "--resolution 40 --samples 6 --quiet --denoise --denoiser nfor "
              "--threads 2");
  INFO(nfor.output);
  REQUIRE(nfor.status == 0);
  auto method   = denoise_params{};
  method.method = denoise_method::nfor;
  auto expected = denoise_image(make_denoise_buffers(state.buffer), method);
  auto written  = load_image(nfor_out);
  auto differs  = 0;
  for (size_t idx = 0; idx < expected.size(); idx++) {
    CHECK(written.pixels[idx].y == expected[idx].y);
    differs += written.pixels[idx].y != final.pixels[idx].y;
  }
  CHECK(differs > (int)expected.size() / 2);
}
