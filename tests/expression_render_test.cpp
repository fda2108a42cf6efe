// Render tests of functions that are no distance bounds (expressions,
// warped primitives): camera rays traced by the renderer against a
// dense-sampling reference written here (no Lipschitz assumption: the sign
// of the function at thousands of points along each ray, NaN outside, the
// first change bisected), hit by hit, distance by distance and normal by
// normal; the accelerated and the reference mode; the infix and the .vm form
// of one function; an expression sphere and the `sphere` primitive; an
// unbounded surface refused.

#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "scene/scene_io.h"
#include "sdf/sdf_tape.h"
#include "sdf/sdf_vm_io.h"
#include "trace/render.h"
#include "util/error.h"

using namespace implicit;

namespace {

// A scene of the sdfunctions `objects` (JSON text) seen from (0.3, 0.4, 8)
// down -z, about 6 units across at the origin.
std::string expression_scene(const std::string& objects) {
  return R"js({"asset": {"version": "4.2"},
    "cameras": [{"name": "default", "frame": [1, 0, 0, 0, 1, 0, 0, 0, 1,
      0.3, 0.4, 8], "lens": 0.05, "film": 0.036, "aspect": 1}],
    "environments": [{"name": "sky", "emission": [1, 1, 1]}],
    "materials": [{"name": "white", "color": [0.8, 0.8, 0.8]}],
    "sdfunctions": [)js" +
         objects + "]}";
}

std::string expression_object(
    const std::string& formula, const std::string& extra = "") {
  return R"js({"name": "f", "type": "expression", "material": 0,
    "expression": ")js" +
         formula + "\"" + extra + "}";
}

scene_data parse(const std::string& text) {
  auto warnings = std::vector<std::string>{};
  return parse_scene(text, "expression.json", warnings, true);
}

// What a grid of camera rays through pixel centres finds, against the
// reference.
struct ray_agreement {
  int  rays = 0, agree = 0;
  int  hit_mismatch = 0, far = 0, bad_normal = 0;
  long evaluations = 0;  // the tracer's, over all rays
};

// Signed value of the scene's first sdfunction at world points (its whole
// tape, in its own space), NaN counting as outside.
struct dense_reference {
  sdf_tape tape  = {};
  frame3f  frame = {};
  bool     inside(vec3f p) const {
        return eval_sdf(tape, transform_point(frame, p)) < 0;
  }
  // First change of side along the ray in [t0, t1], from `samples` signs
  // (evaluated as one batch).
  bool first_hit(
      const ray3f& ray, float t0, float t1, int samples, float& hit) const {
    auto points = std::vector<vec3f>(samples + 1);
    auto values = std::vector<float>(samples + 1);
    for (auto k = 0; k <= samples; k++)
      points[k] = transform_point(
          frame, ray_point(ray, (float)(t0 + (t1 - t0) * (double)k / samples)));
    eval_sdf(tape, points.data(), values.data(), points.size());
    auto start = values[0] < 0;
    for (auto k = 1; k <= samples; k++) {
      if ((values[k] < 0) == start) continue;
      auto lo = t0 + (t1 - t0) * (double)(k - 1) / samples;
      auto hi = t0 + (t1 - t0) * (double)k / samples;
      for (auto i = 0; i < 40; i++) {
        auto mid = 0.5 * (lo + hi);
        (inside(ray_point(ray, (float)mid)) == start ? lo : hi) = mid;
      }
      hit = (float)lo;
      return true;
    }
    return false;
  }
  // World normal by central differences of the tape.
  vec3f normal(vec3f p, float h) const {
    auto g = vec3f{};
    for (auto a = 0; a < 3; a++) {
      auto e   = vec3f{0, 0, 0};
      at(e, a) = h;
      at(g, a) = eval_sdf(tape, transform_point(frame, p + e)) -
                 eval_sdf(tape, transform_point(frame, p - e));
    }
    return normalize(g);
  }
};

// A grid of `size` x `size` camera rays through pixel centres and the
// reference's first hit of each over `box` (world; it must hold the
// surface: the tracer's own box is not trusted).
struct dense_rays {
  std::vector<ray3f> rays      = {};
  std::vector<bool>  hits      = {};
  std::vector<float> distances = {};
};

dense_rays trace_dense(const scene_data& scene,
    const dense_reference& reference, const bbox3f& box, int size) {
  auto result = dense_rays{};
  for (auto j = 0; j < size; j++) {
    for (auto i = 0; i < size; i++) {
      auto uv  = vec2f{(i + 0.5f) / size, (j + 0.5f) / size};
      auto ray = eval_camera(scene.cameras[0], uv, {0, 0});
      auto t0 = 0.0f, t1 = 0.0f, hit = 0.0f;
      auto found = intersect_bbox(ray, box, t0, t1) &&
                   reference.first_hit(ray, t0, t1, 4000, hit);
      result.rays.push_back(ray);
      result.hits.push_back(found);
      result.distances.push_back(hit);
    }
  }
  return result;
}

// Compare the tracer's hits with the reference's: hit or miss, distance
// within 1e-4 relative, normal within 8 degrees (when `normals`).
ray_agreement compare_dense(const accel_data& accel,
    const dense_reference& reference, const dense_rays& dense, bool normals) {
  auto march  = march_params{};
  auto result = ray_agreement{};
  for (size_t k = 0; k < dense.rays.size(); k++) {
    auto& ray  = dense.rays[k];
    auto  hit  = dense.distances[k];
    auto  isec = intersect_scene(accel, march, ray);
    result.rays++;
    result.evaluations += isec.evaluations;
    if (isec.hit != dense.hits[k]) {
      result.hit_mismatch++;
      continue;
    }
    if (isec.hit && std::abs(isec.distance - hit) > 1e-4f * hit) {
      result.far++;
      continue;
    }
    if (isec.hit && normals) {
      auto n = eval_object_normal(
          accel.objects[isec.object], ray_point(ray, isec.distance), 1e-4f);
      if (dot(n, reference.normal(ray_point(ray, hit), 1e-3f)) < 0.99f) {
        result.bad_normal++;
        continue;
      }
    }
    result.agree++;
  }
  return result;
}

// The scene's camera rays agree with the reference on 99% of pixels, with
// either accel; returns the mean evaluations per ray of each (bvh, none).
std::array<double, 2> check_dense(
    const std::string& text, const bbox3f& box, bool normals = true) {
  auto scene      = parse(text);
  auto reference  = dense_reference{};
  reference.tape  = make_sdf_tape(scene.sdfunctions[0].program);
  reference.frame = scene.sdfunctions[0].local_from_world;
  auto dense      = trace_dense(scene, reference, box, 40);
  auto any_hit    = std::count(dense.hits.begin(), dense.hits.end(), true);
  CHECK(any_hit > 50);
  auto evaluations = std::array<double, 2>{};
  for (auto type : {accel_type::bvh, accel_type::none}) {
    auto accel  = make_accel(scene, type);
    auto result = compare_dense(accel, reference, dense, normals);
    INFO("accel ", std::string{type == accel_type::bvh ? "bvh" : "none"}, ": ",
        result.agree, " of ", result.rays, " agree; hits differ ",
        result.hit_mismatch, ", distances ", result.far, ", normals ",
        result.bad_normal);
    CHECK(result.agree >= 0.99 * result.rays);
    evaluations[type == accel_type::none] =
        (double)result.evaluations / result.rays;
  }
  return evaluations;
}

const auto test_box = bbox3f{{-3, -3, -3}, {3, 3, 3}};

// Render a scene through the render core, as every front end does.
image_data render_text(const std::string& text, accel_type type,
    shader_type shader = shader_type::implicit_normal) {
  auto params       = trace_params{};
  auto scene        = parse(text);
  params.camera     = find_camera(scene, "");
  params.resolution = 48;
  params.samples    = 2;
  params.shader     = shader;
  params.accel      = type;
  auto context      = make_render_context(std::move(scene), params);
  auto image        = image_data{};
  render_image(*context, params, image);
  return image;
}

// Fraction of pixels equal within `tolerance` on every channel.
double equal_fraction(
    const image_data& a, const image_data& b, float tolerance) {
  auto equal = 0;
  for (size_t i = 0; i < a.pixels.size(); i++) {
    auto pa = a.pixels[i], pb = b.pixels[i];
    equal += std::abs(pa.x - pb.x) <= tolerance &&
             std::abs(pa.y - pb.y) <= tolerance &&
             std::abs(pa.z - pb.z) <= tolerance &&
             std::abs(pa.w - pb.w) <= tolerance;
  }
  return (double)equal / a.pixels.size();
}

double coverage(const image_data& image) {
  auto sum = 0.0;
  for (auto& p : image.pixels) sum += p.w;
  return sum / image.pixels.size();
}

}  // namespace

TEST_CASE("expressions: a sphere scaled by 1000 and by 0.001") {
  for (auto scale : {"1000", "0.001"}) {
    INFO("scale ", scale);
    check_dense(expression_scene(expression_object(
                    std::string{scale} + "*(x*x + y*y + z*z - 1)")),
        test_box);
  }
}

TEST_CASE("expressions: a tangle-cube-like quartic") {
  check_dense(expression_scene(expression_object(
                  "0.3*((1.5*x)^4 - 5*(1.5*x)^2 + (1.5*y)^4 - 5*(1.5*y)^2 + "
                  "(1.5*z)^4 - 5*(1.5*z)^2 + 11.8)")),
      test_box);
}

TEST_CASE("expressions: an exp/ln blend") {
  // A soft minimum of two spheres (log-sum-exp), displaced by a sine.
  check_dense(expression_scene(expression_object(
                  "-log(exp(-6*(sqrt(x*x + y*y + z*z) - 1)) + "
                  "exp(-6*(sqrt((x - 1.3)^2 + y*y + z*z) - 0.6)))/6 + "
                  "0.03*sin(9*x)*sin(9*y)")),
      test_box);
}

TEST_CASE("expressions: NaN regions count as outside") {
  // sqrt(x) is NaN for x < 0: half a ball, cut flat at x = 0 (no normals:
  // the cut is where NaN meets the inside); log of a shell.
  check_dense(
      expression_scene(expression_object("x*x + y*y + z*z - 1 + 0*sqrt(x)",
          R"js(, "bounds": [[-2, -2, -2], [2, 2, 2]])js")),
      test_box, false);
  check_dense(
      expression_scene(expression_object("log(1.2 - x*x - y*y - z*z) + 0.2*y",
          R"js(, "bounds": [[-2, -2, -2], [2, 2, 2]])js")),
      test_box, false);
}

TEST_CASE("expressions: operands, transforms and warps") {
  // A smooth union of an expression and a primitive, moved and rounded;
  // a twisted box (a warp makes a primitive no distance bound).
  check_dense(expression_scene(R"js({"name": "blend", "material": 0,
      "type": "round", "radius": 0.05,
      "frame": [1, 0, 0, 0, 0.8, 0.6, 0, -0.6, 0.8, 0.2, -0.1, 0],
      "operand": {"type": "smooth_union", "blend": 0.3, "operands": [
        {"type": "expression", "expression": "10*(x*x/4 + y*y + z*z - 0.5)"},
        {"type": "sphere", "radius": 0.6, "frame": [1, 0, 0, 0, 1, 0, 0, 0, 1,
          1.2, 0, 0]}]}})js"),
      test_box);
  check_dense(expression_scene(R"js({"name": "column", "material": 0,
      "type": "twist", "k": 1.5, "operand": {"type": "box",
      "whd": [0.8, 3, 0.8], "frame": [1, 0, 0, 0, 1, 0, 0, 0, 1,
      -0.4, -1.5, -0.4]}})js"),
      test_box);
}

TEST_CASE("expressions: repetition of a function that is no distance") {
  // Displaced spheres repeated 5 x 5: the value jumps at every border of
  // the repetition (the displacement is not symmetric), and a piece of a
  // ray across a border has no slope bound: the march splits pieces there.
  auto evaluations = check_dense(expression_scene(R"js({"name": "bumps",
      "material": 0, "type": "repeat", "spacing": [0.9, 0, 0.9],
      "limit": [2, 0, 2], "operand": {"type": "displace",
      "expression": "0.05*sin(15*x)*sin(15*y)*sin(15*z)",
      "operand": {"type": "sphere", "radius": 0.3}},
      "frame": [1, 0, 0, 0, 0.8, 0.6, 0, -0.6, 0.8, 0, 0, 0]})js"),
      test_box);
  // 33 evaluations per ray when such pieces were halved down to the hit
  // threshold instead, 18 when split.
  CHECK(evaluations[0] < 25);
  // The same repetition written with mod in a formula.
  auto written = check_dense(
      expression_scene(expression_object(
          "sqrt((mod(x + 0.45, 0.9) - 0.45)^2 + y^2 + (mod(z + 0.45, 0.9) - "
          "0.45)^2) - 0.3 + 0.05*sin(15*(mod(x + 0.45, 0.9) - 0.45))*sin(15*y)*"
          "sin(15*(mod(z + 0.45, 0.9) - 0.45))",
          R"js(, "bounds": [[-2.25, -0.4, -2.25], [2.25, 0.4, 2.25]],
      "frame": [1, 0, 0, 0, 0.8, 0.6, 0, -0.6, 0.8, 0, 0, 0])js")),
      test_box);
  // Split at mod's steps as at the repeat's borders: 9.1 evaluations per
  // ray, 11.9 when only repeat clauses were split.
  CHECK(written[0] < 10.5);
  // Spheres wider than their copies, cut by the borders: there the value
  // jumps from inside to outside, and the cut faces are hit.
  check_dense(expression_scene(R"js({"name": "cut", "material": 0,
      "type": "repeat", "spacing": [0.9, 0.9, 0], "limit": [1, 1, 0],
      "operand": {"type": "displace",
      "expression": "0.05*sin(15*x)*sin(15*y)*sin(15*z)",
      "operand": {"type": "sphere", "radius": 0.55}},
      "frame": [0.8, 0, 0.6, 0, 1, 0, -0.6, 0, 0.8, 0, 0, 0]})js"),
      test_box, false);
}

TEST_CASE("expressions: accelerated and reference modes agree") {
  auto text      = expression_scene(expression_object(
           "0.3*((1.5*x)^4 - 5*(1.5*x)^2 + (1.5*y)^4 - 5*(1.5*y)^2 + "
                "(1.5*z)^4 - 5*(1.5*z)^2 + 11.8)"));
  auto fast      = render_text(text, accel_type::bvh);
  auto reference = render_text(text, accel_type::none);
  CHECK(coverage(fast) > 0.1);
  CHECK(equal_fraction(fast, reference, 0.02f) >= 0.99);
}

TEST_CASE("expressions: an expression sphere renders as the sphere primitive") {
  auto expression = render_text(
      expression_scene(expression_object("0.01*(x*x + y*y + z*z - 2.25)")),
      accel_type::bvh);
  auto primitive = render_text(expression_scene(R"js({"name": "s",
      "material": 0, "type": "sphere", "radius": 1.5})js"),
      accel_type::bvh);
  CHECK(coverage(primitive) > 0.1);
  CHECK(equal_fraction(expression, primitive, 0.02f) >= 0.99);
}

TEST_CASE("expressions: the infix and .vm forms give the same image") {
  auto formula =
      "max(x*x + y*y + z*z - 1.5, -(sqrt(x*x + y*y) - 0.5)) + "
      "0.05*sin(7*z)";
  auto infix  = expression_scene(expression_object(formula));
  auto folder = std::filesystem::temp_directory_path() /
                ("implicit_expression_" + std::to_string((long long)getpid()));
  std::filesystem::create_directories(folder);
  save_vm((folder / "f.vm").string(), parse(infix).sdfunctions[0].program);
  auto vm = expression_scene(
      R"js({"name": "f", "type": "expression", "material": 0, "uri": "f.vm"})js");
  std::ofstream(folder / "vm.json") << vm;
  auto scene_vm = load_scene((folder / "vm.json").string());
  std::filesystem::remove_all(folder);
  auto params       = trace_params{};
  params.resolution = 48;
  params.samples    = 2;
  params.shader     = shader_type::implicit;
  auto render       = [&](scene_data scene) {
    params.camera = find_camera(scene, "");
    auto context  = make_render_context(std::move(scene), params);
    auto image    = image_data{};
    render_image(*context, params, image);
    return image;
  };
  auto a = render(parse(infix));
  auto b = render(std::move(scene_vm));
  CHECK(coverage(a) > 0.1);
  REQUIRE(a.pixels.size() == b.pixels.size());
  CHECK(std::memcmp(a.pixels.data(), b.pixels.data(),
            a.pixels.size() * sizeof(a.pixels[0])) == 0);
}

TEST_CASE("expressions: an unbounded surface is refused, asking for bounds") {
  auto gyroid  = expression_scene(R"js({"name": "gyroid", "material": 0,
      "type": "expression",
      "expression": "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"})js");
  auto message = std::string{};
  try {
    parse(gyroid);
  } catch (const io_error& error) { message = error.what(); }
  CHECK(message.find("expression.json: sdfunctions[0] (\"gyroid\"): ") == 0);
  CHECK(message.find("unbounded") != std::string::npos);
  CHECK(message.find("`bounds`") != std::string::npos);
  // With bounds it loads and renders.
  auto bounded = expression_scene(R"js({"name": "gyroid", "material": 0,
      "type": "expression", "bounds": [[-2, -2, -2], [2, 2, 2]],
      "expression":
        "sin(3*x)*cos(3*y) + sin(3*y)*cos(3*z) + sin(3*z)*cos(3*x)"})js");
  CHECK(coverage(render_text(bounded, accel_type::bvh)) > 0.1);
}

TEST_CASE("expressions: the examples load and show their surfaces") {
  for (auto name :
      {"gyroid_lattice", "twisted_columns", "iq_repeat", "slab_text"}) {
    INFO(name);
    auto scene        = load_scene(std::string{IMPLICIT_SOURCE_DIR} +
                                   "/examples/expressions/" + name + ".json");
    auto params       = trace_params{};
    params.camera     = find_camera(scene, "");
    params.resolution = 24;
    params.samples    = 1;
    params.shader     = shader_type::implicit_normal;
    auto context      = make_render_context(std::move(scene), params);
    auto image        = image_data{};
    render_image(*context, params, image);
    CHECK(coverage(image) > 0.3);
  }
}
