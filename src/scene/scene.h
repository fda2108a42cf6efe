// # implicit: scene
//
// The scene as loaded: cameras, textures, materials, environments, and the
// implicit objects (analytic SDF programs, grid instances, user callables).
// Plain data; elements refer to each other by index.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "../image/image.h"
#include "../math/math.h"
#include "../sdf/sdf_grid.h"
#include "../sdf/sdf_program.h"

namespace implicit {

// -----------------------------------------------------------------------------
// SCENE DATA
// -----------------------------------------------------------------------------

// Camera as in Yocto/GL: looks down -z of its frame; film along the longer
// side.
struct camera_data {
  std::string name         = "";
  frame3f     frame        = {};
  bool        orthographic = false;
  float       lens         = 0.050f;
  float       film         = 0.036f;
  float       aspect       = 1.500f;
  float       focus        = 10000;
  float       aperture     = 0;
};

// A texture: linear RGBA (8-bit files are converted from sRGB at load).
struct texture_data {
  std::string name  = "";
  std::string uri   = "";
  image_data  image = {};
};

// Material types of Yocto/GL 4.2.
enum class material_type {
  // clang-format off
  matte, glossy, reflective, transparent, refractive, subsurface, volumetric, gltfpbr
  // clang-format on
};
inline const std::vector<std::string> material_type_names = {"matte", "glossy",
    "reflective", "transparent", "refractive", "subsurface", "volumetric",
    "gltfpbr"};

// Material as in the JSON file (roughness not yet squared).
struct material_data {
  std::string   name           = "";
  material_type type           = material_type::matte;
  vec3f         emission       = {0, 0, 0};
  vec3f         color          = {0, 0, 0};
  float         metallic       = 0;
  float         roughness      = 0;
  float         ior            = 1.5f;
  float         trdepth        = 0.01f;
  vec3f         scattering     = {0, 0, 0};
  float         scanisotropy   = 0;
  float         opacity        = 1;
  int           emission_tex   = invalidid;
  int           color_tex      = invalidid;
  int           roughness_tex  = invalidid;
  int           scattering_tex = invalidid;
  int           normal_tex     = invalidid;
};

// The scene format's material keys besides name and type: one table that
// the loader checks and reads and the Python module lists. Each key is a
// colour (3 numbers), a number or a texture index, with its valid range.
enum class material_key_kind { color, number, texture };
enum class material_key_range {
  any,
  non_negative,
  positive,
  unit,           // [0, 1]
  open_symmetric  // (-1, 1): Henyey-Greenstein's pdf is infinite at |g| = 1
};
struct material_key {
  const char*        name      = "";
  material_key_kind  kind      = material_key_kind::number;
  material_key_range range     = material_key_range::any;
  vec3f material_data::*color  = nullptr;  // kind color
  float material_data::*number = nullptr;  // kind number
  int material_data::*texture  = nullptr;  // kind texture
};
inline const std::vector<material_key> material_keys = {
    {"emission", material_key_kind::color, material_key_range::non_negative,
        &material_data::emission},
    {"color", material_key_kind::color, material_key_range::non_negative,
        &material_data::color},
    {"metallic", material_key_kind::number, material_key_range::unit, nullptr,
        &material_data::metallic},
    {"roughness", material_key_kind::number, material_key_range::unit, nullptr,
        &material_data::roughness},
    {"ior", material_key_kind::number, material_key_range::positive, nullptr,
        &material_data::ior},
    {"trdepth", material_key_kind::number, material_key_range::positive,
        nullptr, &material_data::trdepth},
    {"scattering", material_key_kind::color, material_key_range::non_negative,
        &material_data::scattering},
    {"scanisotropy", material_key_kind::number,
        material_key_range::open_symmetric, nullptr,
        &material_data::scanisotropy},
    {"opacity", material_key_kind::number, material_key_range::unit, nullptr,
        &material_data::opacity},
    {"emission_tex", material_key_kind::texture, material_key_range::any,
        nullptr, nullptr, &material_data::emission_tex},
    {"color_tex", material_key_kind::texture, material_key_range::any, nullptr,
        nullptr, &material_data::color_tex},
    {"roughness_tex", material_key_kind::texture, material_key_range::any,
        nullptr, nullptr, &material_data::roughness_tex},
    {"scattering_tex", material_key_kind::texture, material_key_range::any,
        nullptr, nullptr, &material_data::scattering_tex},
    {"normal_tex", material_key_kind::texture, material_key_range::any, nullptr,
        nullptr, &material_data::normal_tex},
};

// Environment: emission times an optional lat-long texture.
struct environment_data {
  std::string name         = "";
  frame3f     frame        = {};
  vec3f       emission     = {0, 0, 0};
  int         emission_tex = invalidid;
};

// An analytic SDF object (the seed's `sdfunctions`). The program is evaluated
// at transform_point(local_from_world, p_world).
struct sdf_function_data {
  std::string              name             = "";
  sdf_program              program          = {};
  frame3f                  local_from_world = {};
  int                      material         = invalidid;
  std::vector<std::string> uris = {};  // `.vm` files read, as the scene names
};

// A grid loaded from a file (the seed's `volumes`); null until loaded. Shared
// (never copied) with the trace objects of its instances, so that the accel
// owns what it traces and the scene may move or go away.
struct volume_data {
  std::string                      name = "";
  std::string                      uri  = "";
  std::shared_ptr<const grid_data> grid = nullptr;
};

// A placed grid (the seed's `vol_instances`): `scale` multiplies the grid's
// extent and values; the grid is evaluated at
// transform_point(local_from_world, p_world) / scale - grid_placement(grid)
// (the file's own placement of a .vdb, see grid_data).
struct vol_instance_data {
  std::string name             = "";
  int         volume           = invalidid;
  int         material         = invalidid;
  float       scale            = 1;
  frame3f     local_from_world = {};
};

// An SDF written in C++ (the seed's "in-app defined SDF"). Only user objects
// pay for the indirect call; `bounds` must contain the zero set and
// `lipschitz` bound the function's slope.
struct user_sdf_data {
  std::string                 name             = "";
  std::function<float(vec3f)> eval             = {};
  bbox3f                      bounds           = {};
  float                       lipschitz        = 1;
  frame3f                     local_from_world = {};
  int                         material         = invalidid;
};

// The whole scene.
struct scene_data {
  std::vector<camera_data>       cameras       = {};
  std::vector<texture_data>      textures      = {};
  std::vector<material_data>     materials     = {};
  std::vector<environment_data>  environments  = {};
  std::vector<sdf_function_data> sdfunctions   = {};
  std::vector<volume_data>       volumes       = {};
  std::vector<vol_instance_data> vol_instances = {};
  std::vector<user_sdf_data>     user_sdfs     = {};
  std::string                    copyright     = "";
};

// -----------------------------------------------------------------------------
// SCENE EVALUATION
// -----------------------------------------------------------------------------

// Index of the camera to use: the exact name, else "default", "camera",
// "camera0", "camera1", else 0 (Yocto/GL's find_camera). Throws io_error for
// a name that matches none when `name` is not empty.
int find_camera(const scene_data& scene, const std::string& name);

// Image size for a camera: the longest side is `resolution`.
vec2i camera_resolution(const camera_data& camera, int resolution);

// Camera ray through image point uv in [0,1]^2 (v down) and lens point
// lens_uv on the unit disk.
ray3f eval_camera(const camera_data& camera, vec2f image_uv, vec2f lens_uv);

// Texture lookup (linear RGBA); an invalid index gives white.
vec4f eval_texture(const scene_data& scene, int texture, vec2f uv);
// Start reading the texels eval_texture() will read (a hint, see
// prefetch_image()); nothing for a missing texture.
void prefetch_texture(const scene_data& scene, int texture, vec2f uv);

// Environment radiance along a world direction (sum of all environments).
vec3f eval_environment(const scene_data& scene, vec3f direction);
vec3f eval_environment(const scene_data& scene,
    const environment_data& environment, vec3f direction);
// The same with the environment's inverse frame given, for callers that keep
// it (the tracer's lights_data) rather than invert a 3x3 matrix per ray.
vec3f eval_environment(const scene_data& scene,
    const environment_data& environment, const frame3f& env_from_world,
    vec3f direction);

// Add a camera that frames the scene's bounds when there is none.
void add_missing_camera(scene_data& scene, const bbox3f& bounds);

}  // namespace implicit
