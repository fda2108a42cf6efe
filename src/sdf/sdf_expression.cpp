// # implicit: closed-form expressions (implementation)
//
// A shunting-yard parser: operators wait on one explicit stack, values (node
// indices) on another, and each operator becomes clauses when a looser one,
// a ')' or the end arrives. Nothing recurses, whatever the input.

#include "sdf_expression.h"

#include <charconv>
#include <cmath>
#include <string>
#include <system_error>
#include <vector>

#include "../util/error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// FUNCTIONS
// -----------------------------------------------------------------------------

namespace {

// The infix functions; lowered in lower_call().
enum class function_type {
  sqrt_,
  abs_,
  sin_,
  cos_,
  tan_,
  asin_,
  acos_,
  atan_,
  atan2_,
  exp_,
  log_,
  min_,
  max_,
  floor_,
  ceil_,
  round_,
  mod_,
  clamp_,
  mix_,
  square_,
};

struct function_info {
  const char*   name     = "";
  function_type type     = function_type::sqrt_;
  int           min_args = 1;
  int           max_args = 1;  // < 0: any number
};

const function_info functions[] = {
    {"sqrt", function_type::sqrt_, 1, 1},
    {"abs", function_type::abs_, 1, 1},
    {"sin", function_type::sin_, 1, 1},
    {"cos", function_type::cos_, 1, 1},
    {"tan", function_type::tan_, 1, 1},
    {"asin", function_type::asin_, 1, 1},
    {"acos", function_type::acos_, 1, 1},
    {"atan", function_type::atan_, 1, 1},
    {"atan2", function_type::atan2_, 2, 2},
    {"exp", function_type::exp_, 1, 1},
    {"log", function_type::log_, 1, 1},
    {"min", function_type::min_, 2, -1},
    {"max", function_type::max_, 2, -1},
    {"floor", function_type::floor_, 1, 1},
    {"ceil", function_type::ceil_, 1, 1},
    {"round", function_type::round_, 1, 1},
    {"mod", function_type::mod_, 2, 2},
    {"clamp", function_type::clamp_, 3, 3},
    {"mix", function_type::mix_, 3, 3},
    {"square", function_type::square_, 1, 1},
};
constexpr int num_functions = (int)(sizeof(functions) / sizeof(functions[0]));

// Index of the function `name` in `functions`, or -1.
int find_function(const std::string& name) {
  for (auto i = 0; i < num_functions; i++)
    if (name == functions[i].name) return i;
  return -1;
}

const char* const variable_names[] = {"x", "y", "z"};

// "a, b, c" for messages.
std::string join_names(const std::vector<std::string>& names) {
  auto text = std::string{};
  for (auto& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
}

}  // namespace

const std::vector<std::string> sdf_expression_functions = [] {
  auto names = std::vector<std::string>{};
  for (auto& function : functions) names.push_back(function.name);
  return names;
}();

// True for [A-Za-z_][A-Za-z0-9_]*.
static bool is_identifier(const std::string& name) {
  if (name.empty()) return false;
  for (size_t i = 0; i < name.size(); i++) {
    auto c     = (unsigned char)name[i];
    auto alpha = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
    if (!alpha && !(i > 0 && c >= '0' && c <= '9')) return false;
  }
  return true;
}

bool is_expression_operand_name(const std::string& name) {
  if (!is_identifier(name) || name == "pi" || find_function(name) >= 0)
    return false;
  for (auto variable : variable_names)
    if (name == variable) return false;
  return true;
}

// -----------------------------------------------------------------------------
// TOKENS
// -----------------------------------------------------------------------------

namespace {

enum class token_type {
  number,
  name,
  open,
  close,
  comma,
  plus,
  minus,
  times,
  divide,
  power,
  end
};

struct token {
  token_type type  = token_type::end;
  size_t     begin = 0;  // byte offset in the text
  size_t     end   = 0;
  float      value = 0;  // numbers
};

[[noreturn]] void throw_at(size_t offset, const std::string& problem) {
  throw io_error("column " + std::to_string(offset + 1) + ": " + problem);
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_name_char(char c) {
  return is_digit(c) || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
         c == '_';
}

// The token's text for messages: "name" or 'punctuation', or "the end".
std::string describe(const std::string& text, const token& t) {
  if (t.type == token_type::end) return "the end";
  // Long tokens are cut: a message stays one line.
  constexpr size_t longest = 24;
  auto part = text.substr(t.begin, std::min(t.end - t.begin, longest));
  if (t.end - t.begin > longest) part += "...";
  auto quote = t.type == token_type::number || t.type == token_type::name
                   ? std::string{"\""}
                   : std::string{"'"};
  return quote + part + quote;
}

// Read the number at `offset`: digits, an optional fraction and exponent.
token read_number(const std::string& text, size_t offset) {
  auto t  = token{token_type::number, offset, offset, 0};
  auto n  = text.size();
  auto p  = offset;
  auto at = [&](size_t i) { return i < n ? text[i] : '\0'; };
  while (is_digit(at(p))) p++;
  if (at(p) == '.') p++;
  while (is_digit(at(p))) p++;
  if (at(p) == 'e' || at(p) == 'E') {
    auto q = p + 1;
    if (at(q) == '+' || at(q) == '-') q++;
    if (!is_digit(at(q))) {
      while (is_name_char(at(q))) q++;
      t.end = q;
      throw_at(offset, "bad number " + describe(text, t));
    }
    p = q;
    while (is_digit(at(p))) p++;
  }
  t.end       = p;
  auto result = std::from_chars(text.data() + offset, text.data() + p, t.value);
  if (result.ec == std::errc::result_out_of_range)
    throw_at(offset, "number " + describe(text, t) +
                         " is out of the range of 32-bit floats");
  if (result.ec != std::errc{} || result.ptr != text.data() + p)
    throw_at(offset, "bad number " + describe(text, t));
  return t;
}

// The token that starts at or after `offset` (spaces skipped).
token next_token(const std::string& text, size_t offset) {
  auto n = text.size();
  while (offset < n && (text[offset] == ' ' || text[offset] == '\t' ||
                           text[offset] == '\n' || text[offset] == '\r'))
    offset++;
  if (offset >= n) return {token_type::end, n, n, 0};
  auto c = text[offset];
  if (is_digit(c) || (c == '.' && offset + 1 < n && is_digit(text[offset + 1])))
    return read_number(text, offset);
  if (is_name_char(c)) {
    auto end = offset;
    while (end < n && is_name_char(text[end])) end++;
    return {token_type::name, offset, end, 0};
  }
  auto single = [&](token_type type) {
    return token{type, offset, offset + 1, 0};
  };
  switch (c) {
    case '(': return single(token_type::open);
    case ')': return single(token_type::close);
    case ',': return single(token_type::comma);
    case '+': return single(token_type::plus);
    case '-': return single(token_type::minus);
    case '*': return single(token_type::times);
    case '/': return single(token_type::divide);
    case '^': return single(token_type::power);
    default: break;
  }
  auto printable = c >= 0x20 && c < 0x7f;
  throw_at(offset,
      printable ? "unexpected character '" + std::string(1, c) + "'"
                : "unexpected byte " + std::to_string((int)(unsigned char)c));
}

// -----------------------------------------------------------------------------
// PARSER
// -----------------------------------------------------------------------------

// An operator waiting on the stack.
enum class pending_type { binary, negate, paren, call };

struct pending {
  pending_type type     = pending_type::paren;
  token_type   op       = token_type::plus;  // binary operators
  int          function = -1;                // calls: index in `functions`
  int          args     = 1;                 // calls: arguments so far
  size_t       offset   = 0;                 // where it was written
};

// Binding strength: + - < * / < unary minus < ^.
int precedence(const pending& p) {
  if (p.type == pending_type::negate) return 3;
  switch (p.op) {
    case token_type::plus:
    case token_type::minus: return 1;
    case token_type::times:
    case token_type::divide: return 2;
    default: return 4;  // power
  }
}

struct expression_parser {
  sdf_program&                         program;
  const std::string&                   text;
  std::vector<sdf_expression_operand>& operands;
  int                                  first  = 0;  // first node added
  size_t                               offset = 0;  // current token
  std::vector<int>                     values = {};
  std::vector<pending>                 stack  = {};

  // Append a clause; the size limits are checked here.
  int add(sdf_type type, int left = invalidid, int right = invalidid) {
    if ((int)program.nodes.size() - first >= sdf_max_clauses)
      throw_at(offset, "more than " + std::to_string(sdf_max_clauses) +
                           " clauses (the most one expression may hold)");
    if ((int)program.nodes.size() >= sdf_max_nodes)
      throw_at(offset, "the model would have more than " +
                           std::to_string(sdf_max_nodes) + " nodes");
    auto node  = sdf_node{};
    node.type  = type;
    node.left  = left;
    node.right = right;
    return add_node(program, node);
  }
  int constant(float value) {
    auto index                 = add(sdf_type::math_const);
    program.nodes[index].value = value;
    return index;
  }
  // True when `index` is a constant this parse made (never shared).
  bool is_own_constant(int index) const {
    return index >= first && program.nodes[index].type == sdf_type::math_const;
  }

  int pop_value() {
    auto value = values.back();
    values.pop_back();
    return value;
  }

  int  power(int base, int exponent);
  void apply(const pending& p);
  int  lower_call(const pending& p, const std::vector<int>& args);
  void push_operand(const token& t, const token& after);
  void close(const token& t);
  void comma(const token& t);
  int  parse();
};

// base ^ exponent, lowered as the header says.
int expression_parser::power(int base, int exponent) {
  constexpr auto largest_integer = 16777216.0f;  // 2^24: exact in a float
  if (is_own_constant(exponent)) {
    auto n = program.nodes[exponent].value;
    if (n == 0.5f) return add(sdf_type::math_sqrt, base);
    if (n == std::floor(n) && std::abs(n) <= largest_integer) {
      if (n == 0) return constant(1);
      // Square-and-multiply on |n|.
      auto m      = (long long)std::abs(n);
      auto result = invalidid;
      while (m > 0) {
        if (m & 1)
          result = result < 0 ? base : add(sdf_type::math_mul, result, base);
        m >>= 1;
        if (m > 0) base = add(sdf_type::math_square, base);
      }
      if (n < 0) result = add(sdf_type::math_div, constant(1), result);
      return result;
    }
  }
  auto logarithm = add(sdf_type::math_log, base);
  return add(sdf_type::math_exp, add(sdf_type::math_mul, exponent, logarithm));
}

// Turn a waiting operator into clauses over the values it takes.
void expression_parser::apply(const pending& p) {
  offset = p.offset;
  if (p.type == pending_type::negate) {
    auto value = pop_value();
    if (is_own_constant(value)) {
      program.nodes[value].value = -program.nodes[value].value;
      values.push_back(value);
    } else {
      values.push_back(add(sdf_type::math_neg, value));
    }
    return;
  }
  auto right = pop_value(), left = pop_value();
  switch (p.op) {
    case token_type::plus:
      values.push_back(add(sdf_type::math_add, left, right));
      break;
    case token_type::minus:
      values.push_back(add(sdf_type::math_sub, left, right));
      break;
    case token_type::times:
      values.push_back(add(sdf_type::math_mul, left, right));
      break;
    case token_type::divide:
      values.push_back(add(sdf_type::math_div, left, right));
      break;
    default: values.push_back(power(left, right)); break;
  }
}

// The clauses of a call to p.function with the argument values `args`.
int expression_parser::lower_call(
    const pending& p, const std::vector<int>& args) {
  offset     = p.offset;
  auto unary = [&](sdf_type type) { return add(type, args[0]); };
  auto fold  = [&](sdf_type type) {
    auto root = args[0];
    for (size_t i = 1; i < args.size(); i++) root = add(type, root, args[i]);
    return root;
  };
  switch (functions[p.function].type) {
    case function_type::sqrt_: return unary(sdf_type::math_sqrt);
    case function_type::abs_: return unary(sdf_type::math_abs);
    case function_type::sin_: return unary(sdf_type::math_sin);
    case function_type::cos_: return unary(sdf_type::math_cos);
    case function_type::tan_: return unary(sdf_type::math_tan);
    case function_type::asin_: return unary(sdf_type::math_asin);
    case function_type::acos_: return unary(sdf_type::math_acos);
    case function_type::atan_: return unary(sdf_type::math_atan);
    case function_type::exp_: return unary(sdf_type::math_exp);
    case function_type::log_: return unary(sdf_type::math_log);
    case function_type::floor_: return unary(sdf_type::math_floor);
    case function_type::ceil_: return unary(sdf_type::math_ceil);
    case function_type::round_: return unary(sdf_type::math_round);
    case function_type::square_: return unary(sdf_type::math_square);
    case function_type::atan2_: return fold(sdf_type::math_atan2);
    case function_type::mod_: return fold(sdf_type::math_mod);
    case function_type::min_: return fold(sdf_type::math_min);
    case function_type::max_: return fold(sdf_type::math_max);
    case function_type::clamp_:
      return add(sdf_type::math_min, add(sdf_type::math_max, args[0], args[1]),
          args[2]);
    case function_type::mix_: {
      auto difference = add(sdf_type::math_sub, args[1], args[0]);
      return add(sdf_type::math_add, args[0],
          add(sdf_type::math_mul, difference, args[2]));
    }
  }
  return invalidid;
}

// A number, variable, operand or a call's name (with its '(' in `after`).
void expression_parser::push_operand(const token& t, const token& after) {
  offset = t.begin;
  if (t.type == token_type::number) {
    values.push_back(constant(t.value));
    return;
  }
  auto name = text.substr(t.begin, t.end - t.begin);
  if (after.type == token_type::open) {
    auto function = find_function(name);
    if (function < 0)
      throw_at(t.begin,
          "unknown function " + describe(text, t) +
              " (functions: " + join_names(sdf_expression_functions) + ")");
    stack.push_back(
        {pending_type::call, token_type::end, function, 1, t.begin});
    return;
  }
  for (auto i = 0; i < 3; i++) {
    if (name == variable_names[i]) {
      values.push_back(add((sdf_type)((int)sdf_type::math_x + i)));
      return;
    }
  }
  if (name == "pi") {
    values.push_back(constant(3.14159265358979f));
    return;
  }
  for (auto& operand : operands) {
    if (name == operand.name) {
      operand.uses++;
      values.push_back(operand.root);
      return;
    }
  }
  if (find_function(name) >= 0)
    throw_at(after.begin, "expected '(' after the function " + name);
  auto known = std::string{"x, y, z, pi"};
  for (auto& operand : operands) known += ", " + operand.name;
  throw_at(t.begin,
      "unknown variable " + describe(text, t) + " (variables: " + known + ")");
}

// A ')': close the innermost parenthesis or call.
void expression_parser::close(const token& t) {
  while (!stack.empty() && (stack.back().type == pending_type::binary ||
                               stack.back().type == pending_type::negate)) {
    apply(stack.back());
    stack.pop_back();
  }
  if (stack.empty()) throw_at(t.begin, "unexpected ')' (no '(' to close)");
  auto p = stack.back();
  stack.pop_back();
  if (p.type == pending_type::paren) return;
  auto& function = functions[p.function];
  if (p.args < function.min_args ||
      (function.max_args >= 0 && p.args > function.max_args)) {
    auto expected = function.max_args < 0
                        ? "at least " + std::to_string(function.min_args)
                        : std::to_string(function.min_args);
    auto plural   = function.min_args == 1 && function.max_args == 1 ? "" : "s";
    throw_at(p.offset, std::string{function.name} + " takes " + expected +
                           " argument" + plural + ", found " +
                           std::to_string(p.args));
  }
  auto args = std::vector<int>(values.end() - p.args, values.end());
  values.resize(values.size() - p.args);
  values.push_back(lower_call(p, args));
}

// A ',': the next argument of the innermost call.
void expression_parser::comma(const token& t) {
  while (!stack.empty() && (stack.back().type == pending_type::binary ||
                               stack.back().type == pending_type::negate)) {
    apply(stack.back());
    stack.pop_back();
  }
  if (stack.empty() || stack.back().type != pending_type::call)
    throw_at(t.begin, "',' outside the arguments of a function");
  stack.back().args++;
}

int expression_parser::parse() {
  first               = (int)program.nodes.size();
  auto expect_operand = true;
  auto t              = next_token(text, 0);
  while (true) {
    auto after = next_token(text, t.end);
    if (expect_operand) {
      switch (t.type) {
        case token_type::number:
        case token_type::name:
          push_operand(t, after);
          if (t.type == token_type::name && after.type == token_type::open) {
            after = next_token(text, after.end);  // the call's '('
          } else {
            expect_operand = false;
          }
          break;
        case token_type::open:
          stack.push_back(
              {pending_type::paren, token_type::end, -1, 0, t.begin});
          break;
        case token_type::minus:
          stack.push_back(
              {pending_type::negate, token_type::minus, -1, 0, t.begin});
          break;
        case token_type::plus: break;  // unary plus
        default:
          throw_at(t.begin,
              "expected a number, a variable, a function or '(', found " +
                  describe(text, t));
      }
    } else {
      switch (t.type) {
        case token_type::plus:
        case token_type::minus:
        case token_type::times:
        case token_type::divide:
        case token_type::power: {
          auto op = pending{pending_type::binary, t.type, -1, 0, t.begin};
          auto right_associative = t.type == token_type::power;
          while (!stack.empty() &&
                 (stack.back().type == pending_type::binary ||
                     stack.back().type == pending_type::negate)) {
            auto top = precedence(stack.back()), own = precedence(op);
            if (top < own || (top == own && right_associative)) break;
            apply(stack.back());
            stack.pop_back();
          }
          stack.push_back(op);
          expect_operand = true;
          break;
        }
        case token_type::close: close(t); break;
        case token_type::comma:
          comma(t);
          expect_operand = true;
          break;
        case token_type::end: {
          while (!stack.empty()) {
            if (stack.back().type == pending_type::paren ||
                stack.back().type == pending_type::call)
              throw_at(t.begin, "expected ')'");
            apply(stack.back());
            stack.pop_back();
          }
          return drop_unused_nodes(program, first, values.back());
        }
        default:
          throw_at(t.begin, "expected an operator, found " + describe(text, t));
      }
    }
    t = after;
  }
}

}  // namespace

int parse_sdf_expression(sdf_program& program, const std::string& text,
    std::vector<sdf_expression_operand>& operands) {
  auto parser = expression_parser{program, text, operands};
  // A failed parse leaves the program as it was.
  auto size = program.nodes.size();
  try {
    return parser.parse();
  } catch (...) {
    program.nodes.resize(size);
    throw;
  }
}

int parse_sdf_expression(sdf_program& program, const std::string& text) {
  auto operands = std::vector<sdf_expression_operand>{};
  return parse_sdf_expression(program, text, operands);
}

int drop_unused_nodes(sdf_program& program, int first, int root) {
  auto& nodes = program.nodes;
  auto  n     = (int)nodes.size();
  if (root < first) {
    nodes.resize(first);
    return root;
  }
  // Users come after their operands: one backward pass marks what the root
  // reaches, one forward pass moves the kept nodes down.
  auto keep          = std::vector<char>(n - first, 0);
  keep[root - first] = 1;
  for (auto i = n - 1; i >= first; i--) {
    if (!keep[i - first]) continue;
    for (auto operand : {nodes[i].left, nodes[i].right})
      if (operand >= first) keep[operand - first] = 1;
  }
  auto index = std::vector<int>(n - first, invalidid);
  auto count = first;
  for (auto i = first; i < n; i++) {
    if (!keep[i - first]) continue;
    auto node = nodes[i];
    if (node.left >= first) node.left = index[node.left - first];
    if (node.right >= first) node.right = index[node.right - first];
    index[i - first] = count;
    nodes[count++]   = node;
  }
  nodes.resize(count);
  return index[root - first];
}

}  // namespace implicit
