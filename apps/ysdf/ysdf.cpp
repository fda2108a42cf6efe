// # ysdf: the companion tool for SDF grids
//
//   ysdf info FILE                       header and statistics
//   ysdf convert IN OUT                  between formats (by extension)
//   ysdf bake OUT --voxel S --shape ...  analytic SDFs (or a scene, an
//                                        --expression, a --vm file) -> grid
//   ysdf from-mesh MESH OUT --voxel S    triangle mesh -> grid (OpenVDB)
//   ysdf to-mesh GRID OUT                grid (or a scene or .vm file, baked
//                                        at --voxel) -> triangle mesh
//   ysdf types                           the scene format's sdfunction types
//
// Grid formats by extension: .vdb (OpenVDB level set), .vol (Mitsuba 3),
// .sdf/.df/.vox2 (SDFGen text or skanti binary; reading detects which from
// the first bytes unless --binary or --text says so, writing makes text
// unless --binary). Errors print one line `ysdf: <message>`, exit code 1.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "scene/scene_io.h"
#include "sdf/sdf_expression.h"
#include "sdf/sdf_grid.h"
#include "sdf/sdf_grid_io.h"
#include "sdf/sdf_mesh.h"
#include "sdf/sdf_mesh_io.h"
#include "sdf/sdf_operator_table.h"
#include "sdf/sdf_primitives.h"
#include "sdf/sdf_program.h"
#include "sdf/sdf_vm_io.h"
#include "util/error.h"
#include "util/file.h"

using namespace implicit;

namespace {

// -----------------------------------------------------------------------------
// FORMATS AND MESSAGES
// -----------------------------------------------------------------------------

// Format of a grid to read: by extension, then by the first bytes (SDFGen
// text starts with digits and spaces, a skanti header with int32 dims).
grid_format input_format(const std::string& filename, bool binary, bool text) {
  auto ext = path_extension(filename);
  if (ext == ".vdb") return grid_format::vdb;
  if (ext == ".vol") return grid_format::mitsuba;
  if (binary) return grid_format::skanti;
  if (text) return grid_format::sdfgen;
  auto file = mapped_file{filename};
  for (auto i = 0; i < (int)std::min(file.size, size_t{16}); i++) {
    auto c = file.data[i];
    if (!std::isdigit((unsigned char)c) && !std::isspace((unsigned char)c) &&
        c != '-' && c != '+' && c != '.' && c != 'e' && c != 'E')
      return grid_format::skanti;
  }
  return grid_format::sdfgen;
}

// Format of a grid to write: by extension; .sdf is text unless --binary.
grid_format output_format(const std::string& filename, bool binary) {
  auto ext = path_extension(filename);
  if (ext == ".vdb") return grid_format::vdb;
  if (ext == ".vol") return grid_format::mitsuba;
  if (ext == ".df" || ext == ".vox2") return grid_format::skanti;
  if (ext == ".sdf") return binary ? grid_format::skanti : grid_format::sdfgen;
  throw_io_error(filename,
      "unknown grid extension '" + ext + "' (use .sdf, .vdb or .vol)");
}

std::string format_label(grid_format format) {
  switch (format) {
    case grid_format::sdfgen: return "sdfgen (SDFGen text)";
    case grid_format::skanti: return "skanti (binary, 80-byte header)";
    case grid_format::vdb: return "vdb (OpenVDB float level set)";
    case grid_format::mitsuba: return "mitsuba (VOL v3, float32)";
  }
  return "";
}

// Progress and notes on stderr, unless --quiet.
struct reporter {
  bool quiet    = false;
  bool terminal = false;
};

void note(const reporter& r, const std::string& message) {
  if (!r.quiet) std::fprintf(stderr, "ysdf: %s\n", message.c_str());
}

// A progress line rewritten in place on a terminal.
void progress(const reporter& r, const std::string& what, int done, int total) {
  if (r.quiet || !r.terminal) return;
  std::fprintf(stderr, "\rysdf: %s %3d%%", what.c_str(),
      total > 0 ? (int)(100.0 * done / total) : 100);
  if (done >= total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

std::string vec_text(vec3f v) {
  char buffer[96];
  std::snprintf(buffer, sizeof(buffer), "%g %g %g", v.x, v.y, v.z);
  return buffer;
}

std::string dims_text(vec3i d) {
  return std::to_string(d.x) + " x " + std::to_string(d.y) + " x " +
         std::to_string(d.z);
}

// Seconds since `start`.
double elapsed(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

void save_and_report(const reporter& r, const std::string& filename,
    const grid_data& grid, bool binary) {
  auto format = output_format(filename, binary);
  save_grid(filename, grid, format);
  note(r, "wrote " + filename + ": " + grid_format_names[(int)format] + ", " +
              dims_text(grid.dims) + " samples, spacing " +
              std::to_string(grid.spacing) + ", origin " +
              vec_text(grid.origin));
}

// -----------------------------------------------------------------------------
// INFO
// -----------------------------------------------------------------------------

void run_info(const std::string& filename, bool binary, bool text) {
  auto format = input_format(filename, binary, text);
  auto start  = std::chrono::steady_clock::now();
  auto grid   = load_grid(filename, format);
  auto load_s = elapsed(start);
  auto stats  = compute_grid_stats(grid);
  auto extent = grid_bounds(grid).max;
  std::printf("file:     %s\n", filename.c_str());
  std::printf("format:   %s\n", format_label(format).c_str());
  std::printf("dims:     %s (%lld samples)\n", dims_text(grid.dims).c_str(),
      (long long)grid_samples(grid.dims));
  std::printf("spacing:  %g\n", grid.spacing);
  std::printf("origin:   %s (first sample in file units; %s)\n",
      vec_text(grid.origin).c_str(),
      grid.placed_by_file ? "scenes place the grid by it"
                          : "scenes put it at the instance's origin");
  if (grid.file_active_voxels >= 0) {
    std::printf("active:   %lld voxels (%.1f%% of the dense box)\n",
        (long long)grid.file_active_voxels,
        100.0 * (double)grid.file_active_voxels /
            (double)grid_samples(grid.dims));
    std::printf("band:     +-%g (background, %g voxels)\n",
        grid.file_background, grid.file_background / grid.spacing);
  }
  std::printf("extent:   %s\n", vec_text(extent).c_str());
  std::printf("values:   %g .. %g\n", stats.min, stats.max);
  std::printf(
      "inside:   %lld samples < 0\n", (long long)stats.negative_samples);
  std::printf("surface:  %lld voxels with a zero crossing\n",
      (long long)stats.surface_voxels);
  std::printf("boundary: %lld samples < 0 on the box%s\n",
      (long long)stats.negative_boundary,
      stats.negative_boundary ? " (the box closes the surface there)" : "");
  std::printf("memory:   %.2f MiB (samples and empty-space skipping)\n",
      grid_memory(grid) / (1024.0 * 1024.0));
  std::printf("loaded:   %.3f s\n", load_s);
  if (stats.min > 0)
    std::printf(
        "note:     every value is > 0: no surface (an unsigned distance "
        "field?); it renders as nothing\n");
  if (stats.max < 0)
    std::printf("note:     every value is < 0: the solid fills the box\n");
}

// -----------------------------------------------------------------------------
// BAKE
// -----------------------------------------------------------------------------

// One shape of the command line: "TYPE key=value ...", a primitive with
// the JSON keys of scene files (size=x,y,z for arrays), read and checked
// by the scene loader (parse_primitive_text), and at=x,y,z (where the
// shape's local origin goes); a leading '-' subtracts it.
struct shape_spec {
  sdf_program program  = {};
  vec3f       at       = {0, 0, 0};
  bool        subtract = false;
};

vec3f parse_at(const std::string& text, const std::string& source) {
  auto parts = std::vector<std::string>{};
  auto item  = std::string{};
  auto in    = std::istringstream(text);
  while (std::getline(in, item, ',')) parts.push_back(item);
  auto at = vec3f{0, 0, 0};
  for (auto k = 0; k < 3 && parts.size() == 3; k++) {
    auto end    = (char*)nullptr;
    (&at.x)[k]  = std::strtof(parts[k].c_str(), &end);
    auto finite = std::isfinite((&at.x)[k]);
    if (parts[k].empty() || *end != 0 || !finite) parts.clear();
  }
  if (parts.size() != 3)
    throw io_error(
        source + ": at: needs 3 numbers x,y,z, found '" + text + "'");
  return at;
}

shape_spec parse_shape(const std::string& spec) {
  auto words = std::vector<std::string>{};
  auto in    = std::istringstream(spec);
  for (auto word = std::string{}; in >> word;) words.push_back(word);
  if (words.empty()) throw io_error("--shape: empty shape");
  auto source = "--shape \"" + spec + "\"";
  auto shape  = shape_spec{};
  auto type   = words[0];
  if (!type.empty() && type[0] == '-') {
    shape.subtract = true;
    type           = type.substr(1);
  }
  auto values = std::vector<std::pair<std::string, std::string>>{};
  for (auto i = size_t{1}; i < words.size(); i++) {
    auto eq = words[i].find('=');
    if (eq == std::string::npos)
      throw io_error(source + ": '" + words[i] + "' is not key=value");
    auto key = words[i].substr(0, eq), value = words[i].substr(eq + 1);
    if (key == "at") {
      shape.at = parse_at(value, source);
    } else {
      values.push_back({key, value});
    }
  }
  shape.program = parse_primitive_text(type, values, source);
  return shape;
}

// Union (smooth with blend > 0) of the shapes, minus the subtracted ones,
// combined as a scene's `operands` lists are (fold_sdf_operands).
sdf_program make_shapes_program(
    const std::vector<shape_spec>& shapes, float blend) {
  auto program    = sdf_program{};
  auto added      = std::vector<int>{};
  auto subtracted = std::vector<int>{};
  for (auto& shape : shapes) {
    auto node = append_program(program, shape.program);
    if (shape.at != vec3f{0, 0, 0})
      node = add_transform(
          program, node, frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -shape.at});
    (shape.subtract ? subtracted : added).push_back(node);
  }
  if (added.empty()) {
    if (!subtracted.empty())
      throw io_error("--shape: subtracting from nothing");
    return program;
  }
  auto op   = sdf_node{};
  op.blend  = blend;
  op.type   = blend > 0 ? sdf_type::op_smooth_union : sdf_type::op_union;
  auto root = fold_sdf_operands(program, added, op);
  if (subtracted.empty()) return program;
  subtracted.insert(subtracted.begin(), root);
  op.type =
      blend > 0 ? sdf_type::op_smooth_subtraction : sdf_type::op_subtraction;
  fold_sdf_operands(program, subtracted, op);
  return program;
}

// Union of a scene's sdfunctions, each in its own frame.
sdf_program make_scene_program(const std::string& filename) {
  auto scene   = load_scene(filename);
  auto program = sdf_program{};
  auto roots   = std::vector<int>{};
  for (auto& function : scene.sdfunctions) {
    auto node = append_program(program, function.program);
    roots.push_back(add_transform(program, node, function.local_from_world));
  }
  if (roots.empty()) throw_io_error(filename, "the scene has no sdfunctions");
  auto op = sdf_node{};
  op.type = sdf_type::op_union;
  fold_sdf_operands(program, roots, op);
  return program;
}

// A formula of --expression (sdf_expression.h).
sdf_program make_expression_program(const std::string& text) {
  auto program = sdf_program{};
  try {
    parse_sdf_expression(program, text);
  } catch (const io_error& error) {
    throw io_error(std::string{"--expression: "} + error.what());
  }
  return program;
}

// A `.vm` file (sdf_vm_io.h).
sdf_program make_vm_program(const std::string& filename) {
  auto program = sdf_program{};
  load_vm(program, filename);
  return program;
}

// Where and how finely to sample a program.
struct sample_options {
  std::vector<float> bounds = {};  // xmin ymin zmin xmax ymax zmax, or none
  float              voxel  = 0;
  int                pad    = 2;
};

// Sample a program on a grid over its bounds (or the given ones).
grid_data bake_program(const sdf_program& program,
    const sample_options& options, const reporter& r) {
  if (options.pad < 0) throw io_error("bake: --pad must be >= 0");
  auto bounds = bbox3f{};
  if (!options.bounds.empty()) {
    auto& b = options.bounds;
    bounds  = {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
  } else {
    bounds = sdf_bounds(program);
    if (!is_finite(bounds) || is_empty(bounds))
      throw io_error(
          "bake: the shapes are unbounded (a plane?); give --bounds");
  }
  bounds     = expand(bounds, options.pad * options.voxel);
  auto start = std::chrono::steady_clock::now();
  auto grid  = bake_grid(program, identity_frame, bounds, options.voxel,
       [&](int done, int total) { progress(r, "baking", done, total); });
  note(r, "baked " + std::to_string(grid_samples(grid.dims)) + " samples in " +
              std::to_string(elapsed(start)) + " s");
  return grid;
}

struct bake_options {
  std::string              output     = "";
  std::string              scene      = "";
  std::string              expression = "";
  std::string              vm         = "";
  std::vector<std::string> shapes     = {};
  sample_options           sampling   = {};
  float                    blend      = 0;
  bool                     binary     = false;
};

void run_bake(const bake_options& options, const reporter& r) {
  auto sources = !options.scene.empty() + !options.shapes.empty() +
                 !options.expression.empty() + !options.vm.empty();
  if (sources != 1)
    throw io_error(
        "bake: give one of --scene, --expression, --vm or one or more "
        "--shape");
  auto program = sdf_program{};
  if (!options.scene.empty()) {
    program = make_scene_program(options.scene);
  } else if (!options.expression.empty()) {
    program = make_expression_program(options.expression);
  } else if (!options.vm.empty()) {
    program = make_vm_program(options.vm);
  } else {
    auto shapes = std::vector<shape_spec>{};
    for (auto& spec : options.shapes) shapes.push_back(parse_shape(spec));
    program = make_shapes_program(shapes, options.blend);
  }
  auto grid = bake_program(program, options.sampling, r);
  save_and_report(r, options.output, grid, options.binary);
}

// -----------------------------------------------------------------------------
// MESHES
// -----------------------------------------------------------------------------

void run_from_mesh(const std::string& input, const std::string& output,
    float voxel, int pad, float shell, bool binary, const reporter& r) {
  auto start = std::chrono::steady_clock::now();
  auto mesh  = load_mesh(input);
  note(r, "read " + std::to_string(mesh.positions.size()) + " vertices, " +
              std::to_string(mesh.triangles.size()) + " triangles in " +
              std::to_string(elapsed(start)) + " s");
  start = std::chrono::steady_clock::now();
  note(r, "converting with OpenVDB meshToVolume (voxel " +
              std::to_string(voxel) + ")...");
  auto grid = grid_data{};
  try {
    grid = mesh_to_grid(mesh, voxel, pad, shell);
  } catch (const io_error& error) { throw_io_error(input, error.what()); }
  note(r, "converted in " + std::to_string(elapsed(start)) + " s");
  save_and_report(r, output, grid, binary);
}

// A grid, or a scene or `.vm` file baked at --voxel, meshed.
void run_to_mesh(const std::string& input, const std::string& output,
    bool binary, bool text, const sample_options& sampling, const reporter& r) {
  auto ext  = path_extension(input);
  auto grid = grid_data{};
  if (ext == ".json" || ext == ".vm") {
    if (!(sampling.voxel > 0))
      throw io_error("to-mesh: a scene or .vm file needs --voxel > 0");
    grid = bake_program(
        ext == ".json" ? make_scene_program(input) : make_vm_program(input),
        sampling, r);
  } else {
    grid = load_grid(input, input_format(input, binary, text));
  }
  auto start = std::chrono::steady_clock::now();
  note(r, "meshing " + dims_text(grid.dims) +
              " samples with OpenVDB volumeToMesh...");
  auto mesh = grid_to_mesh(grid);
  if (mesh.triangles.empty())
    note(r, "the grid has no surface (no value changes sign): empty mesh");
  save_mesh(output, mesh);
  note(r, "wrote " + output + ": " + std::to_string(mesh.positions.size()) +
              " vertices, " + std::to_string(mesh.triangles.size()) +
              " triangles in " + std::to_string(elapsed(start)) + " s");
}

// -----------------------------------------------------------------------------
// TYPES
// -----------------------------------------------------------------------------

// How a primitive parameter is written, for `ysdf types`.
std::string param_text(const sdf_param& param) {
  auto range = param.range == sdf_param_range::positive ? "> 0" : ">= 0";
  return std::string{param.key} + " (" +
         (param.field == sdf_param_field::size ? "array of 3 numbers"
                                               : "number") +
         ", " + range + ")";
}

// The sdfunction types of the scene format: the primitive table's and the
// operator table's rows.
void run_types() {
  std::printf("primitives (sdfunctions \"type\" and required keys):\n");
  for (auto i = 0; i < (int)sdf_type::op_union; i++) {
    auto keys = std::string{};
    for (auto& param : primitive_params((sdf_type)i))
      keys += (keys.empty() ? "" : ", ") + param_text(param);
    std::printf("  %-20s %s\n", sdf_type_names[i].c_str(),
        keys.empty() ? "(no keys)" : keys.c_str());
  }
  auto ranges = std::vector<std::string>{"", ", > 0", ", >= 0"};
  std::printf("\noperators (their operands are nested sdfunction objects):\n");
  for (auto& op : sdf_operators) {
    std::printf("  %-20s %s\n", op.name, op.help);
    for (auto& key : op.keys)
      std::printf("    %-18s %s%s%s: %s\n", key.key,
          sdf_key_type_names[(int)key.type].c_str(),
          ranges[(int)key.range].c_str(), key.required ? "" : ", optional",
          key.help);
  }
}

// The subcommands and what they read.
struct ysdf_command_line {
  std::string    in_file = "", out_file = "";
  bool           binary = false, text = false, in_binary = false;
  bake_options   bake  = {};
  float          voxel = 0, shell = 0;  // from-mesh
  int            pad           = 3;     // from-mesh
  sample_options mesh_sampling = {};    // to-mesh
  CLI::App *     info = nullptr, *convert = nullptr, *bake_cmd = nullptr,
           *from_mesh = nullptr, *to_mesh = nullptr, *types = nullptr;
};

// info and convert.
void add_grid_commands(CLI::App& app, ysdf_command_line& cl) {
  cl.info = app.add_subcommand("info", "Print a grid's header and statistics");
  cl.info->add_option("file", cl.in_file, "Grid file")->required();
  cl.info->add_flag("--binary", cl.binary, "Read a .sdf as skanti binary");
  cl.info->add_flag("--text", cl.text, "Read a .sdf as SDFGen text");

  cl.convert = app.add_subcommand("convert", "Convert a grid between formats");
  cl.convert->add_option("input", cl.in_file, "Grid to read")->required();
  cl.convert
      ->add_option("output", cl.out_file, "Grid to write (.sdf, .vdb, .vol)")
      ->required();
  cl.convert->add_flag("--binary", cl.binary, "Write .sdf as skanti binary");
  cl.convert->add_flag(
      "--in-binary", cl.in_binary, "Read a .sdf as skanti binary");
}

void add_bake_command(CLI::App& app, ysdf_command_line& cl) {
  auto& bake  = cl.bake;
  auto  cmd   = app.add_subcommand("bake", "Bake analytic SDFs into a grid");
  cl.bake_cmd = cmd;
  cmd->add_option("output", bake.output, "Grid to write")->required();
  cmd->add_option("--voxel", bake.sampling.voxel, "Voxel size")->required();
  cmd->add_option("--shape", bake.shapes,
      "Shape \"TYPE key=value ...\": a primitive with the keys of scene "
      "files (x,y,z for arrays; 'ysdf types' lists them) and at=x,y,z; a "
      "leading '-' subtracts; repeat to combine");
  cmd->add_option("--scene", bake.scene, "Scene whose sdfunctions to bake");
  cmd->add_option("--expression", bake.expression,
      "Infix formula over x, y, z to bake (README \"Expressions\")");
  cmd->add_option("--vm", bake.vm, "fidget .vm file to bake");
  cmd->add_option(
      "--blend", bake.blend, "Smooth blend radius for combining shapes");
  cmd->add_option(
      "--pad", bake.sampling.pad, "Padding in voxels around the bounds");
  cmd->add_option("--bounds", bake.sampling.bounds,
         "World box xmin ymin zmin xmax ymax zmax")
      ->expected(6);
  cmd->add_flag("--binary", bake.binary, "Write .sdf as skanti binary");
}

// from-mesh and to-mesh.
void add_mesh_commands(CLI::App& app, ysdf_command_line& cl) {
  cl.from_mesh = app.add_subcommand(
      "from-mesh", "Make a grid from a triangle mesh (OpenVDB)");
  cl.from_mesh->add_option("mesh", cl.in_file, "Mesh to read (.obj, .ply)")
      ->required();
  cl.from_mesh->add_option("output", cl.out_file, "Grid to write")->required();
  cl.from_mesh->add_option("--voxel", cl.voxel, "Voxel size")->required();
  cl.from_mesh->add_option(
      "--pad", cl.pad, "Padding in voxels around the mesh (>= 1)");
  cl.from_mesh->add_option("--shell", cl.shell,
      "Half thickness of a shell around an open mesh (unsigned distance - "
      "shell)");
  cl.from_mesh->add_flag("--binary", cl.binary, "Write .sdf as skanti binary");

  cl.to_mesh = app.add_subcommand(
      "to-mesh", "Extract a triangle mesh from a grid (OpenVDB)");
  cl.to_mesh
      ->add_option("input", cl.in_file,
          "Grid to read, or a scene (.json) or .vm file to bake at --voxel")
      ->required();
  cl.to_mesh->add_option("output", cl.out_file, "Mesh to write (.obj, .ply)")
      ->required();
  cl.to_mesh->add_flag("--binary", cl.binary, "Read a .sdf as skanti binary");
  cl.to_mesh->add_flag("--text", cl.text, "Read a .sdf as SDFGen text");
  cl.to_mesh->add_option("--voxel", cl.mesh_sampling.voxel,
      "Voxel size to bake a scene or .vm file at");
  cl.to_mesh->add_option(
      "--pad", cl.mesh_sampling.pad, "Padding in voxels around the bounds");
  cl.to_mesh
      ->add_option("--bounds", cl.mesh_sampling.bounds,
          "World box xmin ymin zmin xmax ymax zmax")
      ->expected(6);
}

// Run the subcommand that was given.
void run_command(const ysdf_command_line& cl, const reporter& r) {
  if (*cl.info) {
    run_info(cl.in_file, cl.binary, cl.text);
  } else if (*cl.convert) {
    auto grid =
        load_grid(cl.in_file, input_format(cl.in_file, cl.in_binary, false));
    save_and_report(r, cl.out_file, grid, cl.binary);
  } else if (*cl.bake_cmd) {
    run_bake(cl.bake, r);
  } else if (*cl.from_mesh) {
    run_from_mesh(
        cl.in_file, cl.out_file, cl.voxel, cl.pad, cl.shell, cl.binary, r);
  } else if (*cl.to_mesh) {
    run_to_mesh(
        cl.in_file, cl.out_file, cl.binary, cl.text, cl.mesh_sampling, r);
  } else if (*cl.types) {
    run_types();
  }
}

}  // namespace

int main(int argc, const char** argv) {
  auto app =
      CLI::App{"ysdf: inspect, convert, bake and mesh SDF grids", "ysdf"};
  app.require_subcommand(1);
  auto r     = reporter{};
  r.terminal = isatty(fileno(stderr)) != 0;
  app.add_flag("-q,--quiet", r.quiet, "No progress or notes on stderr");
  auto cl = ysdf_command_line{};
  add_grid_commands(app, cl);
  add_bake_command(app, cl);
  add_mesh_commands(app, cl);
  cl.types = app.add_subcommand(
      "types", "List the scene format's sdfunction types and their keys");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "ysdf: %s (see ysdf --help)\n", e.what());
    return 1;
  }
  try {
    run_command(cl, r);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ysdf: %s\n", e.what());
    return 1;
  }
  return 0;
}
