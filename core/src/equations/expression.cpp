// The expression language of the `equations` system: tokenizer, parser, derivative, C++ text (expression.hpp).
#include "equations/expression.hpp"

#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <system_error>

namespace geobarrier::equations {

const std::vector<FunctionInfo> &functions() {
    static const std::vector<FunctionInfo> list = {
        {Function::sin, "sin", 1},   {Function::cos, "cos", 1},   {Function::tan, "tan", 1},
        {Function::asin, "asin", 1}, {Function::acos, "acos", 1}, {Function::atan, "atan", 1},
        {Function::sinh, "sinh", 1}, {Function::cosh, "cosh", 1}, {Function::tanh, "tanh", 1},
        {Function::exp, "exp", 1},   {Function::log, "log", 1},   {Function::sqrt, "sqrt", 1},
        {Function::cbrt, "cbrt", 1}, {Function::abs, "abs", 1},   {Function::atan2, "atan2", 2},
        {Function::sign, "sign", 1},
    };
    return list;
}

namespace {

const FunctionInfo *find_function(const std::string &name) {
    for (const FunctionInfo &f : functions())
        if (name == f.name) return &f;
    return nullptr;
}

const FunctionInfo &info_of(Function function) {
    for (const FunctionInfo &f : functions())
        if (f.function == function) return f;
    throw Error("equations: unknown function");
}

bool is_letter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

Expr make(Kind kind, std::vector<Expr> args = {}) {
    auto n = std::make_shared<Node>();
    n->kind = kind;
    n->args = std::move(args);
    return n;
}

Expr leaf(Kind kind, std::size_t index = 0) {
    auto n = std::make_shared<Node>();
    n->kind = kind;
    n->index = index;
    return n;
}

// ------------------------------------------------------------ tokens

struct Token {
    enum Type { number, name, plus, minus, star, slash, caret, open, close, comma, end } type = end;
    std::string text;
    std::size_t column = 0; // 1-based
    double value = 0.0;
};

std::string describe(const Token &t) {
    switch (t.type) {
    case Token::number:
        return "the number " + t.text;
    case Token::name:
        return "'" + t.text + "'";
    case Token::end:
        return "the end of the expression";
    default:
        return "'" + t.text + "'";
    }
}

class Parser {
  public:
    Parser(const std::string &text, const Symbols &symbols, const std::string &path)
        : m_symbols(symbols), m_path(path) {
        tokenize(text);
    }

    Expr parse_all() {
        if (m_tokens.size() == 1) throw ConfigError(m_path, "the expression is empty");
        Expr e = expression(0);
        const Token &t = peek();
        if (t.type == Token::close) fail(t, "unbalanced ')': there is no '(' for it to close");
        if (t.type != Token::end)
            fail(t, "expected an operator (+ - * / ^) or the end of the expression, found " + describe(t));
        return e;
    }

  private:
    [[noreturn]] void fail(const Token &t, const std::string &message) const {
        throw ConfigError(m_path + ", column " + std::to_string(t.column), message);
    }
    [[noreturn]] void fail_at(std::size_t column, const std::string &message) const {
        throw ConfigError(m_path + ", column " + std::to_string(column), message);
    }

    void tokenize(const std::string &text) {
        if (text.size() > max_expression_length)
            throw ConfigError(m_path, "the expression is " + std::to_string(text.size()) +
                                          " characters long; at most " + std::to_string(max_expression_length) +
                                          " are allowed");
        std::size_t i = 0;
        while (i < text.size()) {
            const char c = text[i];
            const std::size_t column = i + 1;
            const auto byte = static_cast<unsigned char>(c);
            if (byte >= 0x80) {
                char hex[8];
                std::snprintf(hex, sizeof hex, "0x%02X", byte);
                fail_at(column, std::string("non-ASCII character (byte ") + hex +
                                    "); expressions are plain ASCII: names, numbers, + - * / ^ ( ) ,");
            }
            if (c == ' ' || c == '\t') {
                ++i;
                continue;
            }
            Token t;
            t.column = column;
            if (is_digit(c) || (c == '.' && i + 1 < text.size() && is_digit(text[i + 1]))) {
                std::size_t j = i;
                while (j < text.size() && is_digit(text[j])) ++j;
                if (j < text.size() && text[j] == '.') {
                    ++j;
                    while (j < text.size() && is_digit(text[j])) ++j;
                }
                if (j < text.size() && (text[j] == 'e' || text[j] == 'E')) {
                    std::size_t k = j + 1;
                    if (k < text.size() && (text[k] == '+' || text[k] == '-')) ++k;
                    if (k < text.size() && is_digit(text[k])) {
                        while (k < text.size() && is_digit(text[k])) ++k;
                        j = k;
                    }
                }
                t.type = Token::number;
                t.text = text.substr(i, j - i);
                const auto parsed = std::from_chars(t.text.data(), t.text.data() + t.text.size(), t.value);
                if (parsed.ec != std::errc() || !std::isfinite(t.value))
                    fail_at(column, "the number " + t.text + " is outside the range of a double");
                i = j;
            } else if (is_letter(c) || c == '_') {
                std::size_t j = i;
                while (j < text.size() && (is_letter(text[j]) || is_digit(text[j]) || text[j] == '_')) ++j;
                t.type = Token::name;
                t.text = text.substr(i, j - i);
                if (t.text.size() > max_name_length)
                    fail_at(column, "the name '" + t.text.substr(0, max_name_length) + "...' is longer than " +
                                        std::to_string(max_name_length) + " characters");
                i = j;
            } else {
                switch (c) {
                case '+':
                    t.type = Token::plus;
                    break;
                case '-':
                    t.type = Token::minus;
                    break;
                case '*':
                    t.type = Token::star;
                    break;
                case '/':
                    t.type = Token::slash;
                    break;
                case '^':
                    t.type = Token::caret;
                    break;
                case '(':
                    t.type = Token::open;
                    break;
                case ')':
                    t.type = Token::close;
                    break;
                case ',':
                    t.type = Token::comma;
                    break;
                default: {
                    char shown[32];
                    if (byte < 0x20 || byte == 0x7f)
                        std::snprintf(shown, sizeof shown, "control character 0x%02X", byte);
                    else
                        std::snprintf(shown, sizeof shown, "character '%c'", c);
                    fail_at(column, "unexpected " + std::string(shown) +
                                        "; expected a number, a name, an operator + - * / ^, ',' or parentheses");
                }
                }
                t.text = std::string(1, c);
                ++i;
            }
            m_tokens.push_back(std::move(t));
        }
        Token end;
        end.type = Token::end;
        end.column = text.size() + 1;
        m_tokens.push_back(end);
    }

    const Token &peek() const { return m_tokens[m_next]; }
    const Token &next() { return m_tokens[m_next == m_tokens.size() - 1 ? m_next : m_next++]; }

    Expr expression(std::size_t depth) {
        Expr e = term(depth);
        while (peek().type == Token::plus || peek().type == Token::minus) {
            const bool plus = next().type == Token::plus;
            Expr r = term(depth);
            e = plus ? add(e, r) : subtract(e, r);
        }
        return e;
    }

    Expr term(std::size_t depth) {
        Expr e = unary(depth);
        while (peek().type == Token::star || peek().type == Token::slash) {
            const bool times = next().type == Token::star;
            Expr r = unary(depth);
            e = times ? multiply(e, r) : divide(e, r);
        }
        return e;
    }

    // Every nesting (sign, exponent, parentheses, call) comes through here, so the depth check bounds the recursion.
    Expr unary(std::size_t depth) {
        if (depth >= max_nesting_depth)
            fail(peek(), "the expression is nested deeper than " + std::to_string(max_nesting_depth) +
                             " levels (parentheses, function calls, signs and exponents)");
        if (peek().type == Token::minus) {
            next();
            return negate(unary(depth + 1));
        }
        if (peek().type == Token::plus) {
            next();
            return unary(depth + 1);
        }
        Expr base = primary(depth);
        if (peek().type == Token::caret) { // right-associative and above the sign: -x^2 = -(x^2), 2^-1 = 0.5
            next();
            return power(base, unary(depth + 1));
        }
        return base;
    }

    void expect_close(const Token &open, bool in_call) {
        const Token &t = peek();
        if (t.type == Token::close) {
            next();
            return;
        }
        const std::string which = "the '(' at column " + std::to_string(open.column);
        if (t.type == Token::end) fail(t, "expected ')' to close " + which);
        fail(t, std::string(in_call ? "expected ',' or ')'" : "expected an operator or ')'") + " to close " + which +
                    ", found " + describe(t));
    }

    Expr primary(std::size_t depth) {
        const Token t = next();
        switch (t.type) {
        case Token::number:
            return number(t.value);
        case Token::open: {
            Expr e = expression(depth + 1);
            expect_close(t, false);
            return e;
        }
        case Token::name:
            return name(t, depth);
        case Token::end:
            fail(t, "the expression ends early; expected a number, a name or '('");
        default:
            fail(t, "expected a number, a name or '(', found " + describe(t));
        }
    }

    Expr name(const Token &t, std::size_t depth) {
        const FunctionInfo *function = find_function(t.text);
        if (peek().type == Token::open) {
            if (!function) {
                std::string list;
                for (const FunctionInfo &f : functions()) list += (list.empty() ? "" : " ") + std::string(f.name);
                std::vector<std::string> names;
                for (const FunctionInfo &f : functions()) names.emplace_back(f.name);
                const std::string hint = did_you_mean(t.text, names);
                fail(t, "'" + t.text + "' is not a function" + (hint.empty() ? "" : "; did you mean '" + hint + "'?") +
                            " (functions: " + list + ")");
            }
            const Token open = next();
            std::vector<Expr> args;
            if (peek().type != Token::close) {
                args.push_back(expression(depth + 1));
                while (peek().type == Token::comma) {
                    next();
                    args.push_back(expression(depth + 1));
                }
            }
            expect_close(open, true);
            if (args.size() != function->arity)
                fail(t, std::string(function->name) + " takes " + std::to_string(function->arity) + " argument" +
                            (function->arity == 1 ? "" : "s") + ", found " + std::to_string(args.size()));
            return call(function->function, std::move(args));
        }
        if (function) fail(t, "'" + t.text + "' is a function: write " + t.text + "(...)");
        for (std::size_t i = 0; i < m_symbols.state.size(); ++i)
            if (m_symbols.state[i] == t.text) return leaf(Kind::state, i);
        for (std::size_t i = 0; i < m_symbols.constants.size(); ++i)
            if (m_symbols.constants[i] == t.text) return leaf(Kind::constant, i);
        if (t.text == "t") return leaf(Kind::time);
        if (t.text == "f") return leaf(Kind::forcing);
        if (t.text == "pi") return number(3.141592653589793238462643383279502884);
        std::vector<std::string> names = m_symbols.state;
        names.insert(names.end(), m_symbols.constants.begin(), m_symbols.constants.end());
        names.insert(names.end(), {"t", "f", "pi"});
        const std::string hint = did_you_mean(t.text, names);
        if (!hint.empty()) fail(t, "unknown name '" + t.text + "'; did you mean '" + hint + "'?");
        std::string list;
        for (const std::string &n : names) list += (list.empty() ? "" : ", ") + n;
        fail(t, "unknown name '" + t.text + "' (the names here: " + list + ")");
    }

    const Symbols &m_symbols;
    std::string m_path;
    std::vector<Token> m_tokens;
    std::size_t m_next = 0;
};

} // namespace

std::string name_problem(const std::string &name) {
    if (name.empty()) return "a name cannot be empty";
    if (name.size() > max_name_length)
        return "the name is longer than " + std::to_string(max_name_length) + " characters";
    if (!is_letter(name[0])) return "a name starts with a letter (A-Z, a-z)";
    for (const char c : name)
        if (!is_letter(c) && !is_digit(c) && c != '_') return "a name holds only ASCII letters, digits and '_'";
    if (name == "t") return "'t' is reserved for the time";
    if (name == "f") return "'f' is reserved for the forcing's value f(t)";
    if (name == "pi") return "'pi' is reserved for the number pi";
    if (find_function(name)) return "'" + name + "' is reserved for a function";
    return "";
}

Expr parse(const std::string &text, const Symbols &symbols, const std::string &json_path) {
    return Parser(text, symbols, json_path).parse_all();
}

// ------------------------------------------------------------ simplifying constructors

bool is_number(const Expr &e, double v) { return e->kind == Kind::number && e->value == v; }

namespace {
bool both_numbers(const Expr &a, const Expr &b) { return a->kind == Kind::number && b->kind == Kind::number; }
// A folded number, when it is finite; else nothing is folded (the generated code then computes the same inf or nan).
bool fold(double v, Expr &out) {
    if (!std::isfinite(v)) return false;
    out = number(v);
    return true;
}
} // namespace

Expr number(double v) {
    auto n = std::make_shared<Node>();
    n->kind = Kind::number;
    n->value = v;
    return n;
}

Expr negate(Expr a) {
    if (a->kind == Kind::number) return number(-a->value);
    if (a->kind == Kind::negate) return a->args[0];
    return make(Kind::negate, {std::move(a)});
}

Expr add(Expr a, Expr b) {
    Expr folded;
    if (both_numbers(a, b) && fold(a->value + b->value, folded)) return folded;
    if (is_number(a, 0.0)) return b;
    if (is_number(b, 0.0)) return a;
    return make(Kind::add, {std::move(a), std::move(b)});
}

Expr subtract(Expr a, Expr b) {
    Expr folded;
    if (both_numbers(a, b) && fold(a->value - b->value, folded)) return folded;
    if (is_number(b, 0.0)) return a;
    if (is_number(a, 0.0)) return negate(std::move(b));
    return make(Kind::subtract, {std::move(a), std::move(b)});
}

Expr multiply(Expr a, Expr b) {
    Expr folded;
    if (both_numbers(a, b) && fold(a->value * b->value, folded)) return folded;
    if (is_number(a, 0.0) || is_number(b, 0.0)) return number(0.0);
    if (is_number(a, 1.0)) return b;
    if (is_number(b, 1.0)) return a;
    if (is_number(a, -1.0)) return negate(std::move(b));
    if (is_number(b, -1.0)) return negate(std::move(a));
    return make(Kind::multiply, {std::move(a), std::move(b)});
}

Expr divide(Expr a, Expr b) {
    Expr folded;
    if (both_numbers(a, b) && b->value != 0.0 && fold(a->value / b->value, folded)) return folded;
    if (is_number(a, 0.0) && !is_number(b, 0.0)) return number(0.0);
    if (is_number(b, 1.0)) return a;
    return make(Kind::divide, {std::move(a), std::move(b)});
}

Expr power(Expr a, Expr b) {
    Expr folded;
    if (both_numbers(a, b) && fold(std::pow(a->value, b->value), folded)) return folded;
    if (is_number(b, 0.0)) return number(1.0);
    if (is_number(b, 1.0)) return a;
    return make(Kind::power, {std::move(a), std::move(b)});
}

Expr call(Function f, std::vector<Expr> args) {
    auto n = std::make_shared<Node>();
    n->kind = Kind::call;
    n->function = f;
    n->args = std::move(args);
    return n;
}

bool uses(const Expr &e, Kind kind) {
    if (e->kind == kind) return true;
    for (const Expr &a : e->args)
        if (uses(a, kind)) return true;
    return false;
}

std::size_t size(const Expr &e) {
    std::size_t n = 1;
    for (const Expr &a : e->args) n += size(a);
    return n;
}

// ------------------------------------------------------------ derivative

namespace {
Expr square(const Expr &a) { return power(a, number(2.0)); }
Expr call1(Function f, const Expr &a) { return call(f, {a}); }
} // namespace

Expr derivative(const Expr &e, std::size_t i) {
    switch (e->kind) {
    case Kind::number:
    case Kind::constant:
    case Kind::time:
    case Kind::forcing:
        return number(0.0);
    case Kind::state:
        return number(e->index == i ? 1.0 : 0.0);
    default:
        break;
    }
    const Expr &a = e->args[0];
    const Expr da = derivative(a, i);
    switch (e->kind) {
    case Kind::negate:
        return negate(da);
    case Kind::add:
        return add(da, derivative(e->args[1], i));
    case Kind::subtract:
        return subtract(da, derivative(e->args[1], i));
    case Kind::multiply: {
        const Expr &b = e->args[1];
        return add(multiply(da, b), multiply(a, derivative(b, i)));
    }
    case Kind::divide: {
        // (a / b)' = a' / b - a b' / b^2
        const Expr &b = e->args[1];
        const Expr db = derivative(b, i);
        return subtract(divide(da, b), divide(multiply(a, db), square(b)));
    }
    case Kind::power: {
        const Expr &b = e->args[1];
        if (!uses(b, Kind::state)) // (a^b)' = b a^(b-1) a' for an exponent independent of the state
            return multiply(multiply(b, power(a, subtract(b, number(1.0)))), da);
        // (a^b)' = a^b (b' log a + b a' / a)
        return multiply(e, add(multiply(derivative(b, i), call1(Function::log, a)), divide(multiply(b, da), a)));
    }
    case Kind::call: {
        if (is_number(da, 0.0) && (e->args.size() == 1 || is_number(derivative(e->args[1], i), 0.0)))
            return number(0.0);
        switch (e->function) {
        case Function::sin:
            return multiply(call1(Function::cos, a), da);
        case Function::cos:
            return negate(multiply(call1(Function::sin, a), da));
        case Function::tan:
            return multiply(add(number(1.0), square(e)), da);
        case Function::asin:
            return divide(da, call1(Function::sqrt, subtract(number(1.0), square(a))));
        case Function::acos:
            return negate(divide(da, call1(Function::sqrt, subtract(number(1.0), square(a)))));
        case Function::atan:
            return divide(da, add(number(1.0), square(a)));
        case Function::sinh:
            return multiply(call1(Function::cosh, a), da);
        case Function::cosh:
            return multiply(call1(Function::sinh, a), da);
        case Function::tanh:
            return multiply(subtract(number(1.0), square(e)), da);
        case Function::exp:
            return multiply(e, da);
        case Function::log:
            return divide(da, a);
        case Function::sqrt:
            return divide(da, multiply(number(2.0), e));
        case Function::cbrt:
            return divide(da, multiply(number(3.0), square(e)));
        case Function::abs:
            return multiply(call1(Function::sign, a), da);
        case Function::sign:
            return number(0.0); // zero wherever it is differentiable
        case Function::atan2: {
            // atan2(y, x)' = (x y' - y x') / (x^2 + y^2)
            const Expr &x = e->args[1];
            return divide(subtract(multiply(x, da), multiply(a, derivative(x, i))), add(square(a), square(x)));
        }
        }
        break;
    }
    default:
        break;
    }
    throw Error("equations: no derivative rule for a node");
}

// ------------------------------------------------------------ C++ text

namespace {
std::string hex_literal(double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, std::fabs(v), std::chars_format::hex);
    const std::string digits(buf, r.ptr);
    return v < 0 || std::signbit(v) ? "(-0x" + digits + ")" : "0x" + digits;
}
// Every operand text is an atom (s[0], k1, a literal, a call) or parenthesised, so a leading '-' negates all of it.
std::string fma_text(const std::string &a, const std::string &b, const std::string &c) {
    return "gb_fma(" + a + ", " + b + ", " + c + ")";
}
bool small_integer(const Expr &e) {
    return e->kind == Kind::number && e->value == std::floor(e->value) && std::fabs(e->value) <= max_expanded_power;
}
} // namespace

std::string cpp(const Expr &e) {
    switch (e->kind) {
    case Kind::number:
        return hex_literal(e->value);
    case Kind::state:
        return "s[" + std::to_string(e->index) + "]";
    case Kind::constant:
        return "k" + std::to_string(e->index);
    case Kind::time:
        return "t";
    case Kind::forcing:
        return "f";
    case Kind::negate:
        return "(-" + cpp(e->args[0]) + ")";
    case Kind::add: {
        // a * b + c as one multiply-add (gb_fma: the SDK's mul_add, as hand-written fields use it).
        const Expr &a = e->args[0], &b = e->args[1];
        if (a->kind == Kind::multiply) return fma_text(cpp(a->args[0]), cpp(a->args[1]), cpp(b));
        if (b->kind == Kind::multiply) return fma_text(cpp(b->args[0]), cpp(b->args[1]), cpp(a));
        return "(" + cpp(a) + " + " + cpp(b) + ")";
    }
    case Kind::subtract: {
        const Expr &a = e->args[0], &b = e->args[1];
        if (b->kind == Kind::multiply) return fma_text("-" + cpp(b->args[0]), cpp(b->args[1]), cpp(a));
        if (a->kind == Kind::multiply) return fma_text(cpp(a->args[0]), cpp(a->args[1]), "-" + cpp(b));
        return "(" + cpp(a) + " - " + cpp(b) + ")";
    }
    case Kind::multiply:
        return "(" + cpp(e->args[0]) + " * " + cpp(e->args[1]) + ")";
    case Kind::divide:
        return "(" + cpp(e->args[0]) + " / " + cpp(e->args[1]) + ")";
    case Kind::power:
        if (small_integer(e->args[1]))
            return "gb_ipow<" + std::to_string(static_cast<int>(e->args[1]->value)) + ">(" + cpp(e->args[0]) + ")";
        return "pow(" + cpp(e->args[0]) + ", " + cpp(e->args[1]) + ")";
    case Kind::call: {
        std::string out = e->function == Function::sign ? "gb_sign(" : std::string(info_of(e->function).name) + "(";
        for (std::size_t k = 0; k < e->args.size(); ++k) out += (k ? ", " : "") + cpp(e->args[k]);
        return out + ")";
    }
    }
    throw Error("equations: unknown node");
}

} // namespace geobarrier::equations
