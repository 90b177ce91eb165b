// The expression language of the `equations` system (docs/experiment-format.md, "Equations"): a strict tokenizer
// and recursive-descent parser into a small tree, its exact symbolic derivative, and the C++ text of a tree. The
// experiment file is data: only the parsed tree is ever turned into source, never the text the user wrote.
#ifndef GEOBARRIER_EQUATIONS_EXPRESSION_HPP
#define GEOBARRIER_EQUATIONS_EXPRESSION_HPP

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace geobarrier::equations {

// Limits on one expression: its length in characters, and the nesting of parentheses, calls and unary minus.
inline constexpr std::size_t max_expression_length = 1000;
inline constexpr std::size_t max_nesting_depth = 32;
// A name (state component or constant) is [A-Za-z][A-Za-z0-9_]* of at most this many characters.
inline constexpr std::size_t max_name_length = 32;
// Integer powers x^n with |n| up to this become multiplications; larger or fractional ones std::pow.
inline constexpr int max_expanded_power = 64;

enum class Function { sin, cos, tan, asin, acos, atan, sinh, cosh, tanh, exp, log, sqrt, cbrt, abs, atan2, sign };

struct FunctionInfo {
    Function function;
    const char *name;
    unsigned arity;
};
// The functions an expression may call, in the order the docs list them (sign is the derivative of abs and may be
// written too).
const std::vector<FunctionInfo> &functions();

enum class Kind { number, state, constant, time, forcing, negate, add, subtract, multiply, divide, power, call };

struct Node;
using Expr = std::shared_ptr<const Node>;

struct Node {
    Kind kind = Kind::number;
    double value = 0.0;    // number
    std::size_t index = 0; // state component or constant
    Function function = Function::sin;
    std::vector<Expr> args; // operands or call arguments
};

// The names an expression may use besides the functions, `t`, `f` and `pi`.
struct Symbols {
    std::vector<std::string> state;
    std::vector<std::string> constants;
};

// Why a name cannot be declared (reserved, malformed, too long), or "" when it can.
std::string name_problem(const std::string &name);

// Parses one expression. Throws ConfigError at "<json_path>, column N" (1-based) naming what was found and what was
// expected; "<json_path>" alone for problems of the whole text (empty, too long).
Expr parse(const std::string &text, const Symbols &symbols, const std::string &json_path);

// Constructors that fold exact identities (0 + a = a, 1 * a = a, 0 * a = 0, ...) and numbers, so that derivatives
// keep no dead terms and a Jacobian entry that is identically zero is the literal 0.
Expr number(double v);
Expr negate(Expr a);
Expr add(Expr a, Expr b);
Expr subtract(Expr a, Expr b);
Expr multiply(Expr a, Expr b);
Expr divide(Expr a, Expr b);
Expr power(Expr a, Expr b);
Expr call(Function f, std::vector<Expr> args);

bool is_number(const Expr &e, double v);
bool uses(const Expr &e, Kind kind);
// d e / d s_i, exact (chain, product and quotient rules), simplified by the constructors above.
Expr derivative(const Expr &e, std::size_t i);

// C++ text of the tree for the generated plugin: states s[i], constants k<j>, time t, forcing f, numbers as exact
// hexadecimal literals, functions by their std:: names. No name the user wrote appears in it.
std::string cpp(const Expr &e);
// Number of nodes of the tree as emitted (shared subtrees counted each time).
std::size_t size(const Expr &e);

} // namespace geobarrier::equations

#endif // GEOBARRIER_EQUATIONS_EXPRESSION_HPP
