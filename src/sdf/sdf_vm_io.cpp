// # implicit: `.vm` files (implementation)

#include "sdf_vm_io.h"

#include <charconv>
#include <cmath>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "../util/error.h"
#include "../util/file.h"
#include "sdf_expression.h"

namespace implicit {

// -----------------------------------------------------------------------------
// READING
// -----------------------------------------------------------------------------

namespace {

// Number of arguments of each math clause, in enum order from math_const.
#define IMPLICIT_SDF_MATH_ARITY(id, name, operands) operands,
constexpr int math_arity[] = {IMPLICIT_SDF_MATH(IMPLICIT_SDF_MATH_ARITY)};
#undef IMPLICIT_SDF_MATH_ARITY
constexpr int num_math = (int)(sizeof(math_arity) / sizeof(math_arity[0]));

bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

// A token for messages: quoted, cut when long, bytes that are not printable
// shown as '?', so that a binary file gives a one-line message.
std::string quoted(std::string_view token) {
  constexpr size_t longest = 32;
  auto             text    = std::string{"\""};
  for (size_t i = 0; i < token.size() && i < longest; i++) {
    auto c = token[i];
    text += c >= 0x20 && c < 0x7f ? c : '?';
  }
  return text + (token.size() > longest ? "...\"" : "\"");
}

// The opcode's math clause, or -1.
int find_opcode(std::string_view opcode) {
  for (auto i = 0; i < num_math; i++)
    if (opcode == sdf_math_names[i]) return i;
  return -1;
}

// "2 arguments", "1 argument", "no arguments".
std::string arguments(int count) {
  if (count == 0) return "no arguments";
  return std::to_string(count) + (count == 1 ? " argument" : " arguments");
}

struct vm_reader {
  sdf_program&       program;
  const std::string& filename;
  int                line = 0;
  // Each name's node and the line that defined it.
  std::unordered_map<std::string_view, std::pair<int, int>> names = {};

  [[noreturn]] void fail(const std::string& problem) const {
    throw_io_error(filename + ":" + std::to_string(line), problem);
  }

  float read_constant(std::string_view token) const;
  int   read_clause(const std::vector<std::string_view>& tokens, int first);
};

float vm_reader::read_constant(std::string_view token) const {
  auto begin = token.data(), end = token.data() + token.size();
  if (begin < end && *begin == '+') begin++;
  auto value  = 0.0f;
  auto result = std::from_chars(begin, end, value);
  if (result.ec == std::errc::result_out_of_range)
    fail("const " + quoted(token) + " is out of the range of 32-bit floats");
  if (result.ec != std::errc{} || result.ptr != end || !std::isfinite(value))
    fail("const takes a finite number, found " + quoted(token));
  return value;
}

// Append the clause of one line (tokens: name, opcode, arguments).
int vm_reader::read_clause(
    const std::vector<std::string_view>& tokens, int first) {
  if (tokens.size() < 2) fail("missing opcode after " + quoted(tokens[0]));
  auto math = find_opcode(tokens[1]);
  if (math < 0) fail("unknown opcode " + quoted(tokens[1]));
  auto name  = std::string{sdf_math_names[math]};
  auto arity = math_arity[math];
  auto given = (int)tokens.size() - 2;
  auto node  = sdf_node{};
  node.type  = (sdf_type)((int)sdf_type::math_const + math);
  if (node.type == sdf_type::math_const) {
    if (given != 1)
      fail("const takes 1 argument (a number), found " + std::to_string(given));
    node.value = read_constant(tokens[2]);
  } else {
    if (given != arity)
      fail(name + " takes " + arguments(arity) + ", found " +
           std::to_string(given));
    for (auto k = 0; k < arity; k++) {
      auto found = names.find(tokens[2 + k]);
      if (found == names.end())
        fail(quoted(tokens[2 + k]) + " is used before it is defined");
      (k == 0 ? node.left : node.right) = found->second.first;
    }
  }
  if ((int)program.nodes.size() - first >= sdf_max_clauses)
    fail("more than " + std::to_string(sdf_max_clauses) +
         " clauses (the most one expression may hold)");
  if ((int)program.nodes.size() >= sdf_max_nodes)
    fail("the model would have more than " + std::to_string(sdf_max_nodes) +
         " nodes");
  auto index   = add_node(program, node);
  auto defined = names.emplace(tokens[0], std::pair{index, line});
  if (!defined.second)
    fail(quoted(tokens[0]) + " is already defined on line " +
         std::to_string(defined.first->second.second));
  return index;
}

}  // namespace

int parse_vm(sdf_program& program, const std::string& text,
    const std::string& filename) {
  auto reader = vm_reader{program, filename};
  auto first  = (int)program.nodes.size();
  auto root   = invalidid;
  auto tokens = std::vector<std::string_view>{};
  try {
    for (size_t begin = 0; begin < text.size();) {
      auto end = text.find('\n', begin);
      if (end == std::string::npos) end = text.size();
      reader.line++;
      tokens.clear();
      for (auto p = begin; p < end;) {
        while (p < end && is_blank(text[p])) p++;
        auto start = p;
        while (p < end && !is_blank(text[p])) p++;
        if (p > start) tokens.emplace_back(text.data() + start, p - start);
      }
      begin = end + 1;
      if (tokens.empty() || tokens[0][0] == '#') continue;
      root = reader.read_clause(tokens, first);
    }
    if (root < 0)
      throw_io_error(
          filename, "no clauses (the file is empty or holds only comments)");
  } catch (...) {
    program.nodes.resize(first);
    throw;
  }
  return drop_unused_nodes(program, first, root);
}

int load_vm(sdf_program& program, const std::string& filename) {
  auto file = mapped_file{filename};
  if ((long long)file.size > vm_max_file_bytes)
    throw_io_error(filename, "is " + std::to_string(file.size >> 20) +
                                 " MiB, more than a .vm file may be (" +
                                 std::to_string(vm_max_file_bytes >> 20) +
                                 " MiB)");
  return parse_vm(program, std::string(file.data, file.size), filename);
}

// -----------------------------------------------------------------------------
// WRITING
// -----------------------------------------------------------------------------

std::string format_vm(const sdf_program& program, int root) {
  if (root < 0 || root >= (int)program.nodes.size())
    throw io_error("the program has no root to write");
  // Users come after their operands: mark what the root reaches backwards,
  // then write forwards, naming each clause once.
  auto& nodes = program.nodes;
  auto  keep  = std::vector<char>(root + 1, 0);
  keep[root]  = 1;
  for (auto i = root; i >= 0; i--) {
    if (!keep[i]) continue;
    if (!is_math(nodes[i].type))
      throw io_error("the expression holds a " +
                     sdf_type_names[(int)nodes[i].type] +
                     " node, which a .vm file cannot hold (only math "
                     "clauses)");
    for (auto operand : {nodes[i].left, nodes[i].right})
      if (operand >= 0) keep[operand] = 1;
  }
  auto names = std::vector<std::string>(root + 1);
  auto count = 0;
  for (auto i = 0; i <= root; i++) count += keep[i];
  auto text = "# " + std::to_string(count) +
              " clauses written by implicit; the last one is the value\n";
  auto next = 0;
  for (auto i = 0; i <= root; i++) {
    if (!keep[i]) continue;
    auto& node = nodes[i];
    char  buffer[32];
    auto  end = std::to_chars(buffer, buffer + sizeof(buffer), next++, 16).ptr;
    names[i]  = "_" + std::string(buffer, end);
    text += names[i] + " " +
            sdf_math_names[(int)node.type - (int)sdf_type::math_const];
    if (node.type == sdf_type::math_const) {
      end = std::to_chars(buffer, buffer + sizeof(buffer), node.value).ptr;
      text += " " + std::string(buffer, end);
    }
    if (node.left >= 0) text += " " + names[node.left];
    if (node.right >= 0) text += " " + names[node.right];
    text += "\n";
  }
  return text;
}

void save_vm(const std::string& filename, const sdf_program& program) {
  auto text = std::string{};
  try {
    text = format_vm(program, root_node(program));
  } catch (const io_error& error) { throw_io_error(filename, error.what()); }
  write_file(filename, text);
}

}  // namespace implicit
