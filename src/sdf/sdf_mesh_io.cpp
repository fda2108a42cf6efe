// # implicit: triangle mesh files (implementation)

#include "sdf_mesh_io.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <new>
#include <string_view>
#include <vector>

#include "../util/error.h"
#include "../util/file.h"
#include "sdf_grid_file.h"

namespace implicit {

// Error "file:line: message".
[[noreturn]] static void throw_line(
    const std::string& filename, int64_t line, const std::string& message) {
  throw_io_error(filename + ":" + std::to_string(line), message);
}

// Parse a whole token as a number (from_chars does not take a leading '+').
template <typename T>
static bool parse_token(std::string_view token, T& value) {
  if (!token.empty() && token[0] == '+') token.remove_prefix(1);
  auto [ptr, ec] =
      std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc{} && ptr == token.data() + token.size();
}

// Split off the next whitespace-separated token of a line.
static std::string_view next_word(std::string_view& line) {
  auto start = line.find_first_not_of(" \t\r\v\f");
  if (start == std::string_view::npos) {
    line = {};
    return {};
  }
  line.remove_prefix(start);
  auto end   = line.find_first_of(" \t\r\v\f");
  auto token = line.substr(0, end);
  line.remove_prefix(end == std::string_view::npos ? line.size() : end);
  return token;
}

// Fan-triangulate a polygon.
static void add_polygon(mesh_data& mesh, const std::vector<int>& polygon) {
  for (auto i = size_t{2}; i < polygon.size(); i++)
    mesh.triangles.push_back({polygon[0], polygon[i - 1], polygon[i]});
}

// -----------------------------------------------------------------------------
// OBJ
// -----------------------------------------------------------------------------

static mesh_data load_obj(const std::string& filename) {
  auto file    = mapped_file{filename};
  auto text    = std::string_view(file.data, file.size);
  auto mesh    = mesh_data{};
  auto polygon = std::vector<int>{};
  auto line_no = int64_t{0};
  while (!text.empty()) {
    auto end  = text.find('\n');
    auto line = text.substr(0, end);
    text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
    line_no++;
    auto key = next_word(line);
    if (key == "v") {
      float xyz[3];
      for (auto& c : xyz) {
        auto token = next_word(line);
        if (!parse_token(token, c) || !std::isfinite(c))
          throw_line(filename, line_no,
              "vertex: '" +
                  token_excerpt(token.data(), token.data() + token.size()) +
                  "' is not a finite number");
      }
      mesh.positions.push_back({xyz[0], xyz[1], xyz[2]});
    } else if (key == "f") {
      polygon.clear();
      for (auto token = next_word(line); !token.empty();
           token      = next_word(line)) {
        // v, v/vt, v//vn or v/vt/vn: only the position index matters.
        auto index = int64_t{0};
        auto slash = token.find('/');
        auto count = (int64_t)mesh.positions.size();
        if (!parse_token(token.substr(0, slash), index) || index == 0)
          throw_line(filename, line_no,
              "face: '" +
                  token_excerpt(token.data(), token.data() + token.size()) +
                  "' is not a vertex index");
        // Negative indices count back from the last vertex so far.
        auto resolved = index > 0 ? index - 1 : count + index;
        if (resolved < 0 || resolved >= count)
          throw_line(filename, line_no,
              "face: vertex index " + std::to_string(index) +
                  " out of range (" + std::to_string(count) +
                  " vertices so far)");
        polygon.push_back((int)resolved);
      }
      if (polygon.size() < 3)
        throw_line(filename, line_no, "face: fewer than 3 vertices");
      add_polygon(mesh, polygon);
    }
    // Normals, UVs, groups, materials and comments do not matter here.
  }
  return mesh;
}

// Append a float in the shortest form that reads back exactly.
static void append_number(std::string& text, float value) {
  char buffer[32];
  auto [ptr, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  text.append(buffer, ptr);
}

static void save_obj(const std::string& filename, const mesh_data& mesh) {
  auto out  = output_file{filename};
  auto text = std::string{"# written by ysdf (implicit)\n"};
  for (auto& p : mesh.positions) {
    text += "v ";
    append_number(text, p.x);
    text += ' ';
    append_number(text, p.y);
    text += ' ';
    append_number(text, p.z);
    text += '\n';
    if (text.size() > (1 << 20)) {
      write_bytes(out, text.data(), text.size());
      text.clear();
    }
  }
  for (auto& t : mesh.triangles) {
    text += "f " + std::to_string(t.x + 1) + " " + std::to_string(t.y + 1) +
            " " + std::to_string(t.z + 1) + "\n";
    if (text.size() > (1 << 20)) {
      write_bytes(out, text.data(), text.size());
      text.clear();
    }
  }
  write_bytes(out, text.data(), text.size());
  commit_file(out);
}

// -----------------------------------------------------------------------------
// PLY
// -----------------------------------------------------------------------------

// PLY scalar types.
enum class ply_type { i8, u8, i16, u16, i32, u32, f32, f64 };

struct ply_property {
  std::string name       = "";
  ply_type    type       = ply_type::f32;
  bool        is_list    = false;
  ply_type    count_type = ply_type::u8;
};

struct ply_element {
  std::string               name       = "";
  int64_t                   count      = 0;
  std::vector<ply_property> properties = {};
};

static int ply_size(ply_type type) {
  switch (type) {
    case ply_type::i8:
    case ply_type::u8: return 1;
    case ply_type::i16:
    case ply_type::u16: return 2;
    case ply_type::i32:
    case ply_type::u32:
    case ply_type::f32: return 4;
    case ply_type::f64: return 8;
  }
  return 1;
}

static bool parse_ply_type(std::string_view name, ply_type& type) {
  struct entry {
    const char* name;
    ply_type    type;
  };
  static const entry names[] = {{"char", ply_type::i8}, {"int8", ply_type::i8},
      {"uchar", ply_type::u8}, {"uint8", ply_type::u8},
      {"short", ply_type::i16}, {"int16", ply_type::i16},
      {"ushort", ply_type::u16}, {"uint16", ply_type::u16},
      {"int", ply_type::i32}, {"int32", ply_type::i32}, {"uint", ply_type::u32},
      {"uint32", ply_type::u32}, {"float", ply_type::f32},
      {"float32", ply_type::f32}, {"double", ply_type::f64},
      {"float64", ply_type::f64}};
  for (auto& e : names) {
    if (name == e.name) {
      type = e.type;
      return true;
    }
  }
  return false;
}

// Reads PLY values from ascii tokens or little-endian bytes.
struct ply_reader {
  std::string filename = "";
  const char* begin    = nullptr;  // start of the file (for offsets)
  const char* p        = nullptr;
  const char* end      = nullptr;
  bool        ascii    = false;
  int64_t     line     = 0;  // ascii only
};

// Read one value as a double; throws at a short read or a bad token.
static double read_ply_value(ply_reader& r, ply_type type) {
  if (r.ascii) {
    while (r.p < r.end && std::isspace((unsigned char)*r.p)) {
      if (*r.p == '\n') r.line++;
      r.p++;
    }
    auto start = r.p;
    while (r.p < r.end && !std::isspace((unsigned char)*r.p)) r.p++;
    auto value = 0.0;
    if (start == r.p) throw_line(r.filename, r.line, "unexpected end of file");
    if (!parse_token(std::string_view(start, (size_t)(r.p - start)), value))
      throw_line(r.filename, r.line,
          "'" + token_excerpt(start, r.p) + "' is not a number");
    return value;
  }
  auto size = ply_size(type);
  if (r.end - r.p < size)
    throw_io_error(r.filename,
        "byte " + std::to_string(r.p - r.begin) + ": unexpected end of file");
  auto value = 0.0;
  switch (type) {
    case ply_type::i8: value = (int8_t)*r.p; break;
    case ply_type::u8: value = (uint8_t)*r.p; break;
    case ply_type::i16: {
      int16_t v;
      std::memcpy(&v, r.p, 2);
      value = v;
    } break;
    case ply_type::u16: {
      uint16_t v;
      std::memcpy(&v, r.p, 2);
      value = v;
    } break;
    case ply_type::i32: value = read_i32(r.p); break;
    case ply_type::u32: {
      uint32_t v;
      std::memcpy(&v, r.p, 4);
      value = v;
    } break;
    case ply_type::f32: value = read_f32(r.p); break;
    case ply_type::f64: {
      double v;
      std::memcpy(&v, r.p, 8);
      value = v;
    } break;
  }
  r.p += size;
  return value;
}

// Where the reader is, for messages.
static std::string ply_place(const ply_reader& r) {
  return r.ascii ? "line " + std::to_string(r.line)
                 : "byte " + std::to_string(r.p - r.begin);
}

// The PLY header: its elements and format; `text` is left at the body,
// `line_no` at the header's last line.
struct ply_header {
  std::vector<ply_element> elements = {};
  std::string              format   = "";
};
static ply_header parse_ply_header(
    const std::string& filename, std::string_view& text, int64_t& line_no) {
  auto header     = ply_header{};
  auto header_end = false;
  while (!text.empty() && !header_end) {
    auto end  = text.find('\n');
    auto line = text.substr(0, end);
    text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
    line_no++;
    auto key = next_word(line);
    if (line_no == 1) {
      if (key != "ply")
        throw_line(filename, 1, "not a PLY file (no 'ply' magic)");
    } else if (key == "format") {
      header.format = std::string(next_word(line));
      if (header.format == "binary_big_endian")
        throw_line(filename, line_no, "binary big endian PLY is not supported");
      if (header.format != "ascii" && header.format != "binary_little_endian")
        throw_line(filename, line_no, "unknown format '" + header.format + "'");
    } else if (key == "element") {
      auto element = ply_element{};
      element.name = std::string(next_word(line));
      if (!parse_token(next_word(line), element.count) || element.count < 0)
        throw_line(
            filename, line_no, "element " + element.name + ": bad count");
      header.elements.push_back(element);
    } else if (key == "property") {
      if (header.elements.empty())
        throw_line(filename, line_no, "property before any element");
      auto property = ply_property{};
      auto type     = next_word(line);
      if (type == "list") {
        property.is_list = true;
        if (!parse_ply_type(next_word(line), property.count_type))
          throw_line(filename, line_no, "unknown list count type");
        type = next_word(line);
      }
      if (!parse_ply_type(type, property.type))
        throw_line(filename, line_no,
            "unknown property type '" + std::string(type) + "'");
      property.name = std::string(next_word(line));
      header.elements.back().properties.push_back(property);
    } else if (key == "end_header") {
      header_end = true;
    } else if (key != "comment" && key != "obj_info" && !key.empty()) {
      throw_line(
          filename, line_no, "unknown header line '" + std::string(key) + "'");
    }
  }
  if (!header_end) throw_io_error(filename, "PLY header has no end_header");
  if (header.format.empty())
    throw_io_error(filename, "PLY header has no format line");
  return header;
}

// Read one list of element `e` (property `i`); a face's vertex indices
// (i == indices) become a polygon of the mesh.
static void read_ply_list(ply_reader& r, const ply_property& p, int64_t e,
    bool indices, mesh_data& mesh, std::vector<int>& polygon) {
  auto place = ply_place(r);
  auto count = read_ply_value(r, p.count_type);
  if (!(count >= 0) || count > (double)(r.end - r.p))
    throw_io_error(r.filename, place + ": list length " +
                                   std::to_string(count) +
                                   " does not fit in the file");
  if (indices) polygon.clear();
  for (auto n = int64_t{0}; n < (int64_t)count; n++) {
    auto value = read_ply_value(r, p.type);
    if (!indices) continue;
    if (!(value >= 0) || value >= (double)mesh.positions.size())
      throw_io_error(r.filename, place + ": face " + std::to_string(e) +
                                     ": vertex index " + std::to_string(value) +
                                     " out of range");
    polygon.push_back((int)value);
  }
  if (!indices) return;
  if (polygon.size() < 3)
    throw_io_error(r.filename,
        place + ": face " + std::to_string(e) + ": fewer than 3 vertices");
  add_polygon(mesh, polygon);
}

// Read the values of one element: vertices' x, y, z become positions,
// faces' vertex indices polygons; other properties are skipped.
static void read_ply_element(ply_reader& r, const ply_element& element,
    mesh_data& mesh, std::vector<int>& polygon) {
  auto& filename = r.filename;
  // Refuse counts the rest of the file can not hold before reserving.
  auto min_size = int64_t{0};
  for (auto& p : element.properties)
    min_size += r.ascii ? 2 : ply_size(p.is_list ? p.count_type : p.type);
  if (min_size > 0 && element.count > (r.end - r.p) / min_size + 1)
    throw_io_error(filename, "element " + element.name + ": " +
                                 std::to_string(element.count) +
                                 " elements do not fit in the file");
  // An element without properties takes no bytes, whatever its count (a
  // count of 9e18 would otherwise loop for ever): there is nothing to read.
  if (element.properties.empty()) return;
  auto is_vertex = element.name == "vertex", is_face = element.name == "face";
  int  xyz[3]  = {-1, -1, -1};
  auto indices = -1;
  for (auto i = 0; i < (int)element.properties.size(); i++) {
    auto& p = element.properties[i];
    if (is_vertex && !p.is_list && p.name.size() == 1 && p.name[0] >= 'x' &&
        p.name[0] <= 'z')
      xyz[p.name[0] - 'x'] = i;
    if (is_face && p.is_list &&
        (p.name == "vertex_indices" || p.name == "vertex_index"))
      indices = i;
  }
  if (is_vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0))
    throw_io_error(filename, "vertex element has no x, y, z properties");
  if (is_face && indices < 0)
    throw_io_error(filename, "face element has no vertex_indices list");
  if (is_vertex) mesh.positions.reserve((size_t)element.count);
  for (auto e = int64_t{0}; e < element.count; e++) {
    auto position = vec3f{};
    for (auto i = 0; i < (int)element.properties.size(); i++) {
      auto& p = element.properties[i];
      if (p.is_list) {
        read_ply_list(r, p, e, i == indices, mesh, polygon);
        continue;
      }
      auto value = read_ply_value(r, p.type);
      if (i == xyz[0]) position.x = (float)value;
      if (i == xyz[1]) position.y = (float)value;
      if (i == xyz[2]) position.z = (float)value;
    }
    if (!is_vertex) continue;
    if (!isfinite(position))
      throw_io_error(filename,
          ply_place(r) + ": vertex " + std::to_string(e) + " is not finite");
    mesh.positions.push_back(position);
  }
}

static mesh_data load_ply(const std::string& filename) {
  auto file    = mapped_file{filename};
  auto text    = std::string_view(file.data, file.size);
  auto line_no = int64_t{0};
  auto header  = parse_ply_header(filename, text, line_no);
  auto r = ply_reader{filename, file.data, text.data(), file.data + file.size,
      header.format == "ascii", line_no + 1};
  auto mesh    = mesh_data{};
  auto polygon = std::vector<int>{};
  for (auto& element : header.elements)
    read_ply_element(r, element, mesh, polygon);
  return mesh;
}

static void save_ply(const std::string& filename, const mesh_data& mesh) {
  auto out = output_file{filename};
  auto header =
      "ply\nformat binary_little_endian 1.0\ncomment written by ysdf "
      "(implicit)\n"
      "element vertex " +
      std::to_string(mesh.positions.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\n"
      "element face " +
      std::to_string(mesh.triangles.size()) +
      "\nproperty list uchar int vertex_indices\nend_header\n";
  write_bytes(out, header.data(), header.size());
  write_bytes(
      out, mesh.positions.data(), mesh.positions.size() * sizeof(vec3f));
  auto buffer = std::vector<char>{};
  buffer.reserve(13 * 4096);
  for (auto& t : mesh.triangles) {
    char face[13] = {3};
    std::memcpy(face + 1, &t, 12);
    buffer.insert(buffer.end(), face, face + 13);
    if (buffer.size() >= 13 * 4096) {
      write_bytes(out, buffer.data(), buffer.size());
      buffer.clear();
    }
  }
  write_bytes(out, buffer.data(), buffer.size());
  commit_file(out);
}

// -----------------------------------------------------------------------------
// DISPATCH
// -----------------------------------------------------------------------------

mesh_data load_mesh(const std::string& filename) {
  auto ext = path_extension(filename);
  try {
    if (ext == ".obj") return load_obj(filename);
    if (ext == ".ply") return load_ply(filename);
  } catch (const std::bad_alloc&) {
    // Counts are checked against the file size, so this is a file larger
    // than the memory left: still an error that names it.
    throw_io_error(filename, "out of memory loading the mesh");
  }
  throw_io_error(
      filename, "unknown mesh extension '" + ext + "' (use .obj or .ply)");
}

void save_mesh(const std::string& filename, const mesh_data& mesh) {
  auto ext = path_extension(filename);
  if (ext == ".obj") return save_obj(filename, mesh);
  if (ext == ".ply") return save_ply(filename, mesh);
  throw_io_error(
      filename, "unknown mesh extension '" + ext + "' (use .obj or .ply)");
}

}  // namespace implicit
