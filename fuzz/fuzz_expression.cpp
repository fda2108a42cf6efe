// # implicit: fuzz target for infix expressions (sdf_expression.h)
//
// The input is a formula. A parse either throws io_error (a message with
// its column) or gives clauses whose operands come before their users; the
// parsed clauses are then written as a `.vm` file and read back, which must
// give the same clauses.

#include <cstdlib>
#include <string>

#include "../src/sdf/sdf_expression.h"
#include "../src/sdf/sdf_vm_io.h"
#include "fuzz_common.h"

// Longer formulas only parse slower; the parser has no size limit to reach
// below its clause limit.
static constexpr size_t max_expression_bytes = 64 * 1024;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace implicit;
  if (size > max_expression_bytes) return 0;
  auto text    = std::string((const char*)data, size);
  auto program = sdf_program{};
  auto root    = invalidid;
  try {
    root = parse_sdf_expression(program, text);
  } catch (const io_error& error) {
    // The expected outcome for a malformed formula: "column N: ...".
    if (std::string{error.what()}.rfind("column ", 0) != 0) std::abort();
    return 0;
  }
  if (root != root_node(program)) std::abort();
  for (auto i = 0; i < (int)program.nodes.size(); i++) {
    auto& node = program.nodes[i];
    if (!is_math(node.type) || node.left >= i || node.right >= i) std::abort();
  }
  auto again = sdf_program{};
  parse_vm(again, format_vm(program, root), "fuzz.vm");
  if (again.nodes.size() != program.nodes.size()) std::abort();
  return 0;
}
