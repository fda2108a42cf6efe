// # implicit: closed-form expressions
//
// Infix formulas over the local x, y, z (and named operands: shapes already
// in the program) become math clauses of an sdf_program, whose meaning
// sdf_program.h gives. The grammar, loosest binding first:
//
//   sum      = product {("+" | "-") product}          left to right
//   product  = unary {("*" | "/") unary}              left to right
//   unary    = ("-" | "+") unary | power              -x^2 = -(x^2)
//   power    = atom ["^" unary]                       right: 2^3^2 = 2^9
//   atom     = number | "pi" | x | y | z | operand name
//            | function "(" sum {"," sum} ")" | "(" sum ")"
//
// Functions and how they are lowered to clauses (no clause of their own):
//
//   sqrt abs sin cos tan asin acos atan exp floor ceil round square
//                         one clause each; log is the clause `ln`
//   atan2(y, x) mod(a, b) one clause each (mod: a - b floor(a / b), in
//                         [0, |b|), as fidget's rem_euclid)
//   min(a, b, ...) max    2 or more arguments, folded left
//   clamp(v, lo, hi)      min(max(v, lo), hi)
//   mix(a, b, t)          a + (b - a) * t (GLSL's mix; `a` is one clause
//                         used twice)
//   a ^ n, n an integer   constant after folding a unary minus: squares
//                         and products (x^5 = square(square(x)) * x),
//                         1 / a^|n| for n < 0, the constant 1 for n = 0
//   a ^ 0.5               sqrt(a)
//   a ^ b otherwise       exp(b * ln(a)): NaN for a < 0, as pow is for a
//                         non-integer b
//
// A unary minus on a number is folded into the constant (-2 is one clause).
// The parser keeps its own stacks (shunting-yard, Dijkstra 1961): a
// thousand nested parentheses cost memory, never the call stack. Clauses
// that end up unused (a consumed exponent, x^0) are not kept.
#pragma once

#include <string>
#include <vector>

#include "sdf_program.h"

namespace implicit {

// Most clauses one expression (an infix string or a `.vm` file) may add; a
// larger one is refused with its place, before it takes more memory.
inline constexpr int sdf_max_clauses = 1 << 20;

// A name the formula may use for an earlier node of the program (a shape's
// root): every use shares that node. `uses` counts them (set by the parser).
struct sdf_expression_operand {
  std::string name = "";
  int         root = invalidid;
  int         uses = 0;
};

// The infix function names, for messages and documentation.
extern const std::vector<std::string> sdf_expression_functions;

// Whether `name` may name an operand: an identifier that is neither a
// variable (x, y, z), `pi` nor a function.
bool is_expression_operand_name(const std::string& name);

// Parse the formula `text` and append its clauses to `program`; returns the
// root. Throws io_error "column C: problem" (C counts bytes from 1), naming
// the unknown function or variable, the missing ')' and so on; the caller
// prefixes the file and the key.
int parse_sdf_expression(sdf_program& program, const std::string& text,
    std::vector<sdf_expression_operand>& operands);
int parse_sdf_expression(sdf_program& program, const std::string& text);

// Keep only the nodes in [first, end) of `program` that `root` reaches (the
// nodes before `first` stay), renumbering operands; returns the new root.
// For parsers that add clauses and then drop some of them.
int drop_unused_nodes(sdf_program& program, int first, int root);

}  // namespace implicit
