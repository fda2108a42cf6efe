// # implicit: fuzz target for `.vm` files (sdf_vm_io.h)
//
// The input is a `.vm` file. A parse either throws io_error naming the file
// or gives clauses whose operands come before their users; those are
// written by format_vm and read back, which must give the same clauses.

#include <cstdlib>
#include <string>

#include "../src/sdf/sdf_vm_io.h"
#include "fuzz_common.h"

// Larger files only parse slower (the clause limit is 2^20 lines).
static constexpr size_t max_vm_bytes = 256 * 1024;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace implicit;
  if (size > max_vm_bytes) return 0;
  auto text    = std::string((const char*)data, size);
  auto program = sdf_program{};
  auto root    = invalidid;
  try {
    root = parse_vm(program, text, "fuzz.vm");
  } catch (const io_error& error) {
    // The expected outcome for a malformed file: "fuzz.vm[:line]: ...".
    if (std::string{error.what()}.rfind("fuzz.vm", 0) != 0) std::abort();
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
  for (size_t i = 0; i < program.nodes.size(); i++) {
    auto &a = program.nodes[i], &b = again.nodes[i];
    if (a.type != b.type || a.left != b.left || a.right != b.right ||
        !(a.value == b.value))
      std::abort();
  }
  return 0;
}
