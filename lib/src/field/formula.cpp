// The formula compiler: a lexer, a recursive-descent parser that folds literal-only
// subexpressions while it builds the tree, and a code generator that turns the tree into a flat
// list of register operations (Sethi-Ullman ordering, powers by squaring). eval() runs that list
// over a small register file on the stack: no strings, maps, virtual calls or allocation.
#include "qjulia/field/formula.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "field/program.h"
#include "field/quat_functions.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace detail {
namespace {

constexpr std::size_t kMaxFormulaLength = 4096;  // characters
constexpr int kMaxNesting = 64;   // parentheses, calls and unary minus signs inside each other
constexpr int kMaxExponent = 64;  // |n| in h^n

// The functions, in the order of their opcodes in kFuncCodes.
enum class Func : int {
  kConj,
  kInv,
  kNorm,
  kAbs,
  kSqr,
  kExp,
  kLog,
  kSqrt,
  kSin,
  kCos,
  kTan,
  kSinh,
  kCosh,
  kTanh
};

struct FuncName {
  const char* name;
  Func func;
};
constexpr std::array<FuncName, 14> kFunctions = {{{"conj", Func::kConj},
                                                  {"inv", Func::kInv},
                                                  {"norm", Func::kNorm},
                                                  {"abs", Func::kAbs},
                                                  {"sqr", Func::kSqr},
                                                  {"exp", Func::kExp},
                                                  {"log", Func::kLog},
                                                  {"sqrt", Func::kSqrt},
                                                  {"sin", Func::kSin},
                                                  {"cos", Func::kCos},
                                                  {"tan", Func::kTan},
                                                  {"sinh", Func::kSinh},
                                                  {"cosh", Func::kCosh},
                                                  {"tanh", Func::kTanh}}};

constexpr OpCode kFuncCodes[] = {OpCode::kConj, OpCode::kInv, OpCode::kNorm, OpCode::kAbs,
                                 OpCode::kSqr,  OpCode::kExp, OpCode::kLog,  OpCode::kSqrt,
                                 OpCode::kSin,  OpCode::kCos, OpCode::kTan,  OpCode::kSinh,
                                 OpCode::kCosh, OpCode::kTanh};
static_assert(sizeof(kFuncCodes) / sizeof(kFuncCodes[0]) == kFunctions.size());

/// The analytic-function opcodes: a call out of the evaluation loop, kept cold so that the
/// arithmetic opcodes keep their registers.
[[gnu::noinline, gnu::cold]] Quat eval_analytic(OpCode code, const Quat& a, double x) {
  switch (code) {
    case OpCode::kExp:
      return qexp(a);
    case OpCode::kLog:
      return qlog(a);
    case OpCode::kSqrt:
      return qsqrt(a);
    case OpCode::kSin:
      return qsin(a);
    case OpCode::kCos:
      return qcos(a);
    case OpCode::kTan:
      return qtan(a);
    case OpCode::kSinh:
      return qsinh(a);
    case OpCode::kCosh:
      return qcosh(a);
    case OpCode::kTanh:
      return qtanh(a);
    default:  // kPowReal
      return qpow(a, x);
  }
}

bool is_function_name(const std::string& s, Func* func = nullptr) {
  for (const FuncName& f : kFunctions) {
    if (s == f.name) {
      if (func) *func = f.func;
      return true;
    }
  }
  return false;
}

bool is_name_start(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_name_char(char c) { return is_name_start(c) || is_digit(c); }
bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}
bool is_real(const Quat& q) { return q.x == 0 && q.y == 0 && q.z == 0; }

// ---------------------------------------------------------------------------------------------
// Lexer

enum class TokenKind { kEnd, kNumber, kName, kPunct, kBad };

struct Token {
  TokenKind kind = TokenKind::kEnd;
  std::size_t begin = 0, end = 0;  // byte range in the text
  int line = 1, column = 1;        // 1-based
  char punct = 0;                  // kPunct: one of + - * / ^ ( ) [ ] ,
  double value = 0;                // kNumber
  int unit = 0;                    // kNumber: 0 real, 1 i, 2 j, 3 k
};

[[noreturn]] void fail(const Token& t, const std::string& what) {
  throw InvalidInput("formula " + std::to_string(t.line) + ":" + std::to_string(t.column) + ": " +
                     what);
}

std::vector<Token> lex(const std::string& text) {
  std::vector<Token> tokens;
  int line = 1;
  std::size_t line_start = 0;
  std::size_t pos = 0;
  const std::size_t n = text.size();
  auto make = [&](TokenKind kind, std::size_t begin) {
    Token t;
    t.kind = kind;
    t.begin = begin;
    t.line = line;
    t.column = static_cast<int>(begin - line_start) + 1;
    return t;
  };
  while (true) {
    while (pos < n && is_space(text[pos])) {
      if (text[pos] == '\n') {
        ++line;
        line_start = pos + 1;
      }
      ++pos;
    }
    if (pos >= n) {
      Token t = make(TokenKind::kEnd, pos);
      t.end = pos;
      tokens.push_back(t);
      return tokens;
    }
    const char c = text[pos];
    const std::size_t begin = pos;
    if (is_digit(c) || (c == '.' && pos + 1 < n && is_digit(text[pos + 1]))) {
      Token t = make(TokenKind::kNumber, begin);
      while (pos < n && is_digit(text[pos])) ++pos;
      if (pos < n && text[pos] == '.') {
        ++pos;
        while (pos < n && is_digit(text[pos])) ++pos;
      }
      bool negative_exponent = false;
      if (pos < n && (text[pos] == 'e' || text[pos] == 'E')) {
        // An exponent only when digits follow; otherwise "2e" is 2 followed by the name e.
        std::size_t p = pos + 1;
        if (p < n && (text[p] == '+' || text[p] == '-')) {
          negative_exponent = text[p] == '-';
          ++p;
        }
        if (p < n && is_digit(text[p])) {
          pos = p;
          while (pos < n && is_digit(text[pos])) ++pos;
        }
      }
      const auto [ptr, ec] = std::from_chars(text.data() + begin, text.data() + pos, t.value);
      if (ec == std::errc::result_out_of_range) {
        if (!negative_exponent) fail(t, "expected a finite number");
        t.value = 0;  // underflow
      } else if (ec != std::errc() || ptr != text.data() + pos) {
        fail(t, "expected a number");
      }
      // A unit directly after the number: 3i, 0.5k (but 3in is 3 followed by the name in).
      if (pos < n && (text[pos] == 'i' || text[pos] == 'j' || text[pos] == 'k') &&
          !(pos + 1 < n && is_name_char(text[pos + 1]))) {
        t.unit = text[pos] - 'i' + 1;
        ++pos;
      }
      t.end = pos;
      tokens.push_back(t);
    } else if (is_name_start(c)) {
      Token t = make(TokenKind::kName, begin);
      while (pos < n && is_name_char(text[pos])) ++pos;
      t.end = pos;
      tokens.push_back(t);
    } else {
      const bool punct = c == '+' || c == '-' || c == '*' || c == '/' || c == '^' || c == '(' ||
                         c == ')' || c == '[' || c == ']' || c == ',';
      Token t = make(punct ? TokenKind::kPunct : TokenKind::kBad, begin);
      t.punct = punct ? c : 0;
      t.end = ++pos;
      tokens.push_back(t);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Parser: builds a tree in post-order (children before parents), folding literal-only nodes.

enum class NodeKind { kLit, kVar, kConst, kNeg, kFunc, kPow, kPowReal, kAdd, kSub, kMul, kDiv };

struct Node {
  explicit Node(NodeKind k) : kind(k) {}
  NodeKind kind;
  int a = -1, b = -1;  // children
  int n = 0;           // kConst: constant index; kFunc: Func; kPow: exponent
  Quat lit;            // kLit: the value; kPowReal: the exponent in lit.w
};

Quat apply_func(Func f, const Quat& a) {
  switch (f) {
    case Func::kConj:
      return conj(a);
    case Func::kInv:
      return inv(a);
    case Func::kNorm:
      return Quat(norm2(a));
    case Func::kAbs:
      return Quat(abs(a));
    case Func::kSqr:
      return sqr(a);
    default:  // the analytic functions: the code eval() runs
      return eval_analytic(kFuncCodes[static_cast<int>(f)], a, 0);
  }
}

/// a^n by left-to-right binary exponentiation; the generated code performs exactly these steps,
/// so folded and evaluated powers agree to the bit.
Quat apply_pow(const Quat& a, int n) {
  if (n == 0) return Quat(1);
  const unsigned m = static_cast<unsigned>(n < 0 ? -n : n);
  int top = 0;
  while ((m >> (top + 1)) != 0) ++top;
  Quat r = a;
  for (int bit = top - 1; bit >= 0; --bit) {
    r = sqr(r);
    if ((m >> bit) & 1u) r = r * a;
  }
  return n < 0 ? inv(r) : r;
}

class Parser {
 public:
  Parser(const std::vector<Token>& tokens, const std::string& text,
         const std::vector<std::string>& constant_names, Formula::Program& program)
      : tokens_(tokens), text_(text), names_(constant_names), program_(program) {}

  /// Parses the whole text; returns the root node.
  int parse() {
    if (peek().kind == TokenKind::kEnd) fail(peek(), "expected an expression");
    const int root = expr();
    const Token& t = peek();
    if (t.kind != TokenKind::kEnd) {
      if (is_punct(t, '^')) fail(t, "expected an operator (use parentheses to chain powers)");
      fail(t, "expected an operator");
    }
    return root;
  }

  std::vector<Node> nodes;

 private:
  const Token& peek() const { return tokens_[pos_]; }
  const Token& next() { return tokens_[pos_++]; }
  static bool is_punct(const Token& t, char c) {
    return t.kind == TokenKind::kPunct && t.punct == c;
  }
  std::string spelling(const Token& t) const { return text_.substr(t.begin, t.end - t.begin); }

  void enter(const Token& t) {
    if (++depth_ > kMaxNesting) {
      fail(t, "expected at most " + std::to_string(kMaxNesting) +
                  " nested parentheses, calls and signs");
    }
  }
  void leave() { --depth_; }

  void expect_punct(char c, const char* what) {
    if (!is_punct(peek(), c)) fail(peek(), what);
    ++pos_;
  }

  int add(Node node) {
    nodes.push_back(node);
    return static_cast<int>(nodes.size()) - 1;
  }
  int literal(const Quat& q) {
    Node node(NodeKind::kLit);
    node.lit = q;
    return add(node);
  }
  bool is_lit(int id) const { return nodes[id].kind == NodeKind::kLit; }

  /// A unary node; kPowReal takes its exponent in `x`.
  int unary(NodeKind kind, int a, int n = 0, double x = 0) {
    if (is_lit(a)) {
      const Quat q = nodes[a].lit;
      Quat r;
      switch (kind) {
        case NodeKind::kNeg:
          return literal(-q);
        case NodeKind::kFunc:
          r = apply_func(static_cast<Func>(n), q);
          break;
        case NodeKind::kPow:
          return literal(apply_pow(q, n));
        default:  // kPowReal
          r = eval_analytic(OpCode::kPowReal, q, x);
          break;
      }
      // sqrt(-1), log(-2), (-4)^0.5: a coefficient that is not real, though written with reals.
      if (is_real(q) && !is_real(r)) program_.real_literals = false;
      return literal(r);
    }
    Node node(kind);
    node.a = a;
    node.n = n;
    node.lit = Quat(x);
    return add(node);
  }

  int binary(NodeKind kind, int a, int b) {
    if (is_lit(a) && is_lit(b)) {
      const Quat& x = nodes[a].lit;
      const Quat& y = nodes[b].lit;
      switch (kind) {
        case NodeKind::kAdd:
          return literal(x + y);
        case NodeKind::kSub:
          return literal(x - y);
        case NodeKind::kMul:
          return literal(x * y);
        case NodeKind::kDiv:
          return literal(x * inv(y));
        default:
          break;
      }
    }
    Node node(kind);
    node.a = a;
    node.b = b;
    return add(node);
  }

  int expr() {
    int left = term();
    while (is_punct(peek(), '+') || is_punct(peek(), '-')) {
      const NodeKind kind = next().punct == '+' ? NodeKind::kAdd : NodeKind::kSub;
      left = binary(kind, left, term());
    }
    return left;
  }

  int term() {
    int left = unary_minus();
    while (is_punct(peek(), '*') || is_punct(peek(), '/')) {
      const NodeKind kind = next().punct == '*' ? NodeKind::kMul : NodeKind::kDiv;
      left = binary(kind, left, unary_minus());
    }
    return left;
  }

  int unary_minus() {
    if (is_punct(peek(), '-')) {
      enter(peek());
      ++pos_;
      const int operand = unary_minus();
      leave();
      return unary(NodeKind::kNeg, operand);
    }
    return power();
  }

  int power() {
    const int base = primary();
    if (!is_punct(peek(), '^')) return base;
    ++pos_;
    bool negative = false;
    if (is_punct(peek(), '-')) {
      negative = true;
      ++pos_;
    }
    const Token& t = peek();
    if (t.kind != TokenKind::kNumber || t.unit != 0) {
      fail(t, "expected a literal real exponent after '^', such as 2, -1.5 or 0.5");
    }
    ++pos_;
    if (!(t.value <= kMaxExponent)) {
      fail(t, "expected an exponent between -" + std::to_string(kMaxExponent) + " and " +
                  std::to_string(kMaxExponent));
    }
    const double x = negative ? -t.value : t.value;
    if (x != std::trunc(x)) return unary(NodeKind::kPowReal, base, 0, x);
    // An integer value (2, 2.0, 2e0): the exact path of repeated squaring.
    const int n = static_cast<int>(x);
    if (n == 0) return literal(Quat(1));  // h^0 = 1 for every h, as for real numbers
    if (n == 1) return base;
    return unary(NodeKind::kPow, base, n);
  }

  double real_number(bool allow_sign) {
    double sign = 1;
    if (allow_sign && (is_punct(peek(), '-') || is_punct(peek(), '+'))) {
      if (next().punct == '-') sign = -1;
    }
    const Token& t = peek();
    if (t.kind != TokenKind::kNumber || t.unit != 0) fail(t, "expected a real number");
    ++pos_;
    return sign * t.value;
  }

  int primary() {
    const Token& t = peek();
    if (t.kind == TokenKind::kNumber) {
      ++pos_;
      if (t.unit == 0) return literal(Quat(t.value));
      program_.real_literals = false;
      Quat q;
      if (t.unit == 1) q.x = t.value;
      if (t.unit == 2) q.y = t.value;
      if (t.unit == 3) q.z = t.value;
      return literal(q);
    }
    if (t.kind == TokenKind::kName) {
      ++pos_;
      const std::string name = spelling(t);
      if (name == "h") return add(Node(NodeKind::kVar));
      if (name == "i" || name == "j" || name == "k") {
        program_.real_literals = false;
        return literal(name == "i"   ? Quat(0, 1, 0, 0)
                       : name == "j" ? Quat(0, 0, 1, 0)
                                     : Quat(0, 0, 0, 1));
      }
      Func func;
      if (is_function_name(name, &func)) {
        if (!is_punct(peek(), '(')) fail(peek(), "expected '(' after '" + name + "'");
        enter(peek());
        ++pos_;
        const int arg = expr();
        expect_punct(')', "expected ')'");
        leave();
        return unary(NodeKind::kFunc, arg, static_cast<int>(func));
      }
      for (std::size_t i = 0; i < names_.size(); ++i) {
        if (names_[i] == name) {
          program_.used[i] = true;
          Node node(NodeKind::kConst);
          node.n = static_cast<int>(i);
          return add(node);
        }
      }
      std::string known = "h";
      for (const std::string& c : names_) known += ", " + c;
      fail(t, "unknown name '" + name + "' (known: " + known + ")");
    }
    if (is_punct(t, '(')) {
      enter(t);
      ++pos_;
      const int inner = expr();
      expect_punct(')', "expected ')'");
      leave();
      return inner;
    }
    if (is_punct(t, '[')) {
      ++pos_;
      Quat q;
      q.w = real_number(true);
      expect_punct(',', "expected ','");
      q.x = real_number(true);
      expect_punct(',', "expected ','");
      q.y = real_number(true);
      expect_punct(',', "expected ','");
      q.z = real_number(true);
      expect_punct(']', "expected ']'");
      if (!is_real(q)) program_.real_literals = false;
      return literal(q);
    }
    fail(t, "expected an operand");
  }

  const std::vector<Token>& tokens_;
  const std::string& text_;
  const std::vector<std::string>& names_;
  Formula::Program& program_;
  std::size_t pos_ = 0;
  int depth_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Code generation

class CodeGen {
 public:
  CodeGen(const std::vector<Node>& nodes, Formula::Program& program)
      : nodes_(nodes), program_(program), need_(nodes.size(), 0) {
    // Registers: 0 = h, 1.. = used constants, then temporaries.
    const_slot_.assign(program.used.size(), -1);
    for (std::size_t i = 0; i < program.used.size(); ++i) {
      if (!program.used[i]) continue;
      const_slot_[i] = 1 + static_cast<int>(program.used_index.size());
      program.used_index.push_back(static_cast<std::uint8_t>(i));
      if (const_slot_[i] >= kRegisters) too_big();
    }
    first_temp_ = 1 + static_cast<int>(program.used_index.size());
    top_ = first_temp_;
    // Sethi-Ullman register needs; nodes are in post-order so children come first.
    for (std::size_t id = 0; id < nodes.size(); ++id) need_[id] = need_of(nodes[id]);
  }

  void run(int root) {
    const int slot = gen(root);
    program_.result = static_cast<std::uint8_t>(slot);
  }

 private:
  [[noreturn]] static void too_big() {
    throw InvalidInput("formula 1:1: expected a smaller formula (at most " +
                       std::to_string(kRegisters) +
                       " registers for h, the constants and intermediate values)");
  }

  int need_of(const Node& n) const {
    switch (n.kind) {
      case NodeKind::kLit:
      case NodeKind::kVar:
      case NodeKind::kConst:
        return 0;
      case NodeKind::kNeg:
      case NodeKind::kFunc:
      case NodeKind::kPowReal:
        return std::max(need_[n.a], 1);
      case NodeKind::kPow:
        return std::max(need_[n.a], 1) + 1;
      default: {
        const int a = nodes_[n.a].kind == NodeKind::kLit ? 0 : need_[n.a];
        const int b = nodes_[n.b].kind == NodeKind::kLit ? 0 : need_[n.b];
        if (a == b) return a + 1;
        return std::max(a, b);
      }
    }
  }

  bool is_temp(int slot) const { return slot >= first_temp_; }

  int alloc() {
    const int r = top_++;
    if (r >= kRegisters) too_big();
    return r;
  }

  /// A destination for a result computed from `slot`: the slot itself when it is a temporary.
  int dest_for(int slot) { return is_temp(slot) ? slot : alloc(); }

  void emit(OpCode code, int dst, int a = 0, int b = 0, const Quat& lit = Quat()) {
    // Peephole: s*x followed by + t on the same register (the 2*h^3 + 1 of Newton maps).
    if (code == OpCode::kAddReal && !program_.ops.empty()) {
      Op& last = program_.ops.back();
      if (last.code == OpCode::kScale && last.dst == a && dst == a) {
        last.code = OpCode::kScaleAddReal;
        last.lit.x = lit.w;
        return;
      }
    }
    Op op;
    op.code = code;
    op.dst = static_cast<std::uint8_t>(dst);
    op.a = static_cast<std::uint8_t>(a);
    op.b = static_cast<std::uint8_t>(b);
    op.lit = lit;
    program_.ops.push_back(op);
  }

  /// Emits code for node `id` and returns the register holding its value.
  int gen(int id) {
    const Node& n = nodes_[id];
    switch (n.kind) {
      case NodeKind::kVar:
        return 0;
      case NodeKind::kConst:
        return const_slot_[n.n];
      case NodeKind::kLit: {
        const int d = alloc();
        emit(OpCode::kLoad, d, 0, 0, n.lit);
        return d;
      }
      case NodeKind::kNeg: {
        const int s = gen(n.a);
        const int d = dest_for(s);
        emit(OpCode::kNeg, d, s);
        return d;
      }
      case NodeKind::kFunc: {
        const int s = gen(n.a);
        const int d = dest_for(s);
        emit(kFuncCodes[n.n], d, s);
        return d;
      }
      case NodeKind::kPowReal: {
        const int s = gen(n.a);
        const int d = dest_for(s);
        emit(OpCode::kPowReal, d, s, 0, n.lit);  // the exponent in lit.w
        return d;
      }
      case NodeKind::kPow:
        return gen_pow(n);
      default:
        return gen_binary(n);
    }
  }

  int gen_pow(const Node& n) {
    const int s = gen(n.a);
    const int d = dest_for(s);
    if (n.n == -1) {
      emit(OpCode::kInv, d, s);
      return d;
    }
    // Same steps as apply_pow: r = a; per lower bit: r = r^2, then r = r*a if the bit is set.
    const unsigned m = static_cast<unsigned>(n.n < 0 ? -n.n : n.n);
    int top = 0;
    while ((m >> (top + 1)) != 0) ++top;
    const int r = alloc();
    int current = s;
    for (int bit = top - 1; bit >= 0; --bit) {
      emit(OpCode::kSqr, r, current);
      current = r;
      if ((m >> bit) & 1u) emit(OpCode::kMul, r, r, s);
    }
    if (n.n < 0) emit(OpCode::kInv, r, r);
    program_.ops.back().dst = static_cast<std::uint8_t>(d);  // the last step writes the result
    top_ = d + 1;
    return d;
  }

  int gen_binary(const Node& n) {
    const bool lit_a = nodes_[n.a].kind == NodeKind::kLit;
    const bool lit_b = nodes_[n.b].kind == NodeKind::kLit;
    if (lit_b) {  // x op L (both literal was folded by the parser)
      const Quat& l = nodes_[n.b].lit;
      const int s = gen(n.a);
      const int d = dest_for(s);
      switch (n.kind) {
        case NodeKind::kAdd:
          is_real(l) ? emit(OpCode::kAddReal, d, s, 0, l) : emit(OpCode::kAddLit, d, s, 0, l);
          break;
        case NodeKind::kSub:  // x - L == x + (-L) exactly in IEEE arithmetic
          is_real(l) ? emit(OpCode::kAddReal, d, s, 0, -l) : emit(OpCode::kAddLit, d, s, 0, -l);
          break;
        case NodeKind::kMul:
          is_real(l) ? emit(OpCode::kScale, d, s, 0, l) : emit(OpCode::kMulLit, d, s, 0, l);
          break;
        default: {  // x / L = x * inv(L), inverse folded
          const Quat m = inv(l);
          is_real(m) ? emit(OpCode::kScale, d, s, 0, m) : emit(OpCode::kMulLit, d, s, 0, m);
          break;
        }
      }
      return d;
    }
    if (lit_a) {  // L op x
      const Quat& l = nodes_[n.a].lit;
      const int s = gen(n.b);
      const int d = dest_for(s);
      switch (n.kind) {
        case NodeKind::kAdd:
          is_real(l) ? emit(OpCode::kAddReal, d, s, 0, l) : emit(OpCode::kAddLit, d, s, 0, l);
          break;
        case NodeKind::kSub:
          emit(OpCode::kLitSub, d, s, 0, l);
          break;
        case NodeKind::kMul:
          is_real(l) ? emit(OpCode::kScale, d, s, 0, l) : emit(OpCode::kLitMul, d, s, 0, l);
          break;
        default:  // L / x = L * inv(x)
          emit(OpCode::kLitDiv, d, s, 0, l);
          break;
      }
      return d;
    }
    // Evaluate the operand needing more registers first; operand order in the op is kept.
    int sa, sb;
    if (need_[n.b] > need_[n.a]) {
      sb = gen(n.b);
      sa = gen(n.a);
    } else {
      sa = gen(n.a);
      sb = gen(n.b);
    }
    int d;
    if (is_temp(sa) && is_temp(sb)) {
      d = std::min(sa, sb);
    } else if (is_temp(sa)) {
      d = sa;
    } else if (is_temp(sb)) {
      d = sb;
    } else {
      d = alloc();
    }
    switch (n.kind) {
      case NodeKind::kAdd:
        emit(OpCode::kAdd, d, sa, sb);
        break;
      case NodeKind::kSub:
        emit(OpCode::kSub, d, sa, sb);
        break;
      case NodeKind::kMul:
        emit(OpCode::kMul, d, sa, sb);
        break;
      default:
        emit(OpCode::kDiv, d, sa, sb);
        break;
    }
    top_ = d + 1;
    return d;
  }

  const std::vector<Node>& nodes_;
  Formula::Program& program_;
  std::vector<int> need_;
  std::vector<int> const_slot_;
  int first_temp_ = 1;
  int top_ = 1;
};

void check_constant_names(const std::vector<std::string>& names) {
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    bool identifier = !name.empty() && is_name_start(name[0]);
    for (char c : name) identifier = identifier && is_name_char(c);
    if (!identifier) {
      throw InvalidInput("formula constant '" + name +
                         "': expected a name of letters, digits and '_' not starting with a "
                         "digit");
    }
    if (name == "h" || name == "i" || name == "j" || name == "k" || is_function_name(name)) {
      std::string functions;
      for (const FuncName& f : kFunctions) functions += std::string(", ") + f.name;
      throw InvalidInput("formula constant '" + name +
                         "': expected a name other than h (the variable), i, j, k (the units) "
                         "and" +
                         functions.substr(1) + " (the functions)");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (names[j] == name) {
        throw InvalidInput("formula constant '" + name + "': expected each name only once");
      }
    }
  }
}

std::shared_ptr<const Formula::Program> identity_program() {
  static const std::shared_ptr<const Formula::Program> program = [] {
    auto p = std::make_shared<Formula::Program>();
    p->text = "h";
    return p;
  }();
  return program;
}

}  // namespace
}  // namespace detail

Formula::Formula() : program_(detail::identity_program()) {}

Formula Formula::compile(const std::string& text, const std::vector<std::string>& constant_names) {
  using namespace detail;
  if (text.size() > kMaxFormulaLength) {
    throw InvalidInput("formula 1:" + std::to_string(kMaxFormulaLength + 1) +
                       ": expected at most " + std::to_string(kMaxFormulaLength) + " characters");
  }
  check_constant_names(constant_names);
  auto program = std::make_shared<Program>();
  program->text = text;
  program->constant_names = constant_names;
  program->used.assign(constant_names.size(), false);

  const std::vector<Token> tokens = lex(text);
  Parser parser(tokens, text, constant_names, *program);
  const int root = parser.parse();
  CodeGen gen(parser.nodes, *program);
  gen.run(root);
  program->ops.shrink_to_fit();

  Formula f;
  f.program_ = std::move(program);
  return f;
}

Quat Formula::eval(const Quat& h, const Quat* constants) const {
  using detail::OpCode;
  // Uninitialised registers: zeroing 1 KiB per call would cost more than the formula.
  union Register {
    Register() {}
    Quat q;
  };
  std::array<Register, detail::kRegisters> regs;
  const Program& p = *program_;
  regs[0].q = h;
  const std::size_t n_used = p.used_index.size();
  for (std::size_t i = 0; i < n_used; ++i) regs[1 + i].q = constants[p.used_index[i]];
  for (const detail::Op& op : p.ops) {
    const Quat& a = regs[op.a].q;
    Quat r;
    switch (op.code) {
      case OpCode::kLoad:
        r = op.lit;
        break;
      case OpCode::kNeg:
        r = -a;
        break;
      case OpCode::kConj:
        r = conj(a);
        break;
      case OpCode::kInv:
        r = inv(a);
        break;
      case OpCode::kNorm:
        r = Quat(norm2(a));
        break;
      case OpCode::kAbs:
        r = Quat(abs(a));
        break;
      case OpCode::kSqr:
        r = sqr(a);
        break;
      case OpCode::kAdd:
        r = a + regs[op.b].q;
        break;
      case OpCode::kSub:
        r = a - regs[op.b].q;
        break;
      case OpCode::kMul:
        r = a * regs[op.b].q;
        break;
      case OpCode::kDiv:
        r = a * inv(regs[op.b].q);
        break;
      case OpCode::kAddReal:
        r = Quat(a.w + op.lit.w, a.x, a.y, a.z);
        break;
      case OpCode::kAddLit:
        r = a + op.lit;
        break;
      case OpCode::kLitSub:
        r = op.lit - a;
        break;
      case OpCode::kScale:
        r = op.lit.w * a;
        break;
      case OpCode::kMulLit:
        r = a * op.lit;
        break;
      case OpCode::kLitMul:
        r = op.lit * a;
        break;
      case OpCode::kLitDiv:
        r = op.lit * inv(a);
        break;
      case OpCode::kScaleAddReal:
        r = op.lit.w * a;
        r.w += op.lit.x;
        break;
      default:  // the analytic functions, out of line so that the loop stays tight
        r = detail::eval_analytic(op.code, a, op.lit.w);
        break;
    }
    regs[op.dst].q = r;
  }
  return regs[p.result].q;
}

const std::string& Formula::text() const { return program_->text; }

const std::vector<std::string>& Formula::constant_names() const { return program_->constant_names; }

const std::vector<bool>& Formula::constants_used() const { return program_->used; }

bool Formula::has_real_coefficients(const Quat* constants) const {
  if (!program_->real_literals) return false;
  for (std::uint8_t i : program_->used_index) {
    if (!detail::is_real(constants[i])) return false;
  }
  return true;
}

std::size_t Formula::operation_count() const { return program_->ops.size(); }

}  // namespace qjulia
