// # implicit: `.vm` files
//
// fidget's plain-text clause format (mkeeter/fidget, Context::from_text), in
// which fidget, libfive's exporters and the MPR paper's tools write models
// (the Prospero challenge, the bear, the colonnade):
//
//   # a comment (a line whose first character that is not a space is #)
//   _0 var-x
//   _1 square _0
//   _2 const 1.5
//   _3 sub _1 _2          the last clause is the value
//
// One clause a line: a name (any token without spaces), an opcode of
// sdf_math_names (sdf_primitive_table.h) and its arguments, names of earlier
// clauses (`const` takes a number instead). Several clauses may use one
// clause: a model is a graph, and it stays one. Blank lines are skipped;
// clauses the last one does not reach are dropped.
//
// Stricter than fidget, which ignores extra tokens, lets a name be defined
// again and accepts inf and NaN constants: each of those is an error here,
// as are an unknown opcode, a name used before it is defined, a missing
// argument, a bad number and an empty file, all with the file and the line:
// `model.vm:12: unknown opcode "foo"`.
#pragma once

#include <string>

#include "sdf_program.h"

namespace implicit {

// Parse the text of a `.vm` file and append its clauses to `program`;
// returns the root (the last clause). `filename` names it in errors.
int parse_vm(
    sdf_program& program, const std::string& text, const std::string& filename);

// Read and parse a `.vm` file (at most vm_max_file_bytes).
int load_vm(sdf_program& program, const std::string& filename);
inline constexpr long long vm_max_file_bytes = 256ll << 20;

// The `.vm` text of the math clauses that `root` reaches, each once (shared
// clauses stay shared). Throws io_error when `root` reaches a node that is
// not a math clause (a shape or an operator has no opcode).
std::string format_vm(const sdf_program& program, int root);

// Write format_vm() of the program's root to `filename` (whole or not at
// all: write_file of util/file.h).
void save_vm(const std::string& filename, const sdf_program& program);

}  // namespace implicit
