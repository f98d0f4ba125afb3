#include "qp_file.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace springbok::qpfile {
namespace {

struct Token {
  std::string text;
  int line;
};

std::vector<Token> tokenize(const std::string& text) {
  std::vector<Token> tokens;
  std::istringstream stream(text);
  std::string line;
  int number = 0;
  while (std::getline(stream, line)) {
    ++number;
    const auto first = line.find_first_not_of(" \t\r\f\v");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream words(line);
    std::string word;
    while (words >> word) tokens.push_back({word, number});
  }
  return tokens;
}

struct ParseFailure : std::runtime_error {
  ParseFailure(int l, std::string t, const std::string& what) : std::runtime_error(what), line(l), token(std::move(t)) {}
  int line;
  std::string token;
};

class Cursor {
 public:
  explicit Cursor(std::vector<Token> tokens) : tokens_(std::move(tokens)) {}

  const Token& next(const char* what) {
    if (pos_ >= tokens_.size()) {
      const int line = tokens_.empty() ? 1 : tokens_.back().line;
      throw ParseFailure(line, "<end of file>", std::string("unexpected end of file, expected ") + what);
    }
    return tokens_[pos_++];
  }
  void keyword(const char* k) {
    const Token& t = next(k);
    if (t.text != k) throw ParseFailure(t.line, t.text, std::string("expected keyword '") + k + "'");
  }
  double number(const char* what) {
    const Token& t = next(what);
    const char* begin = t.text.c_str();
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(begin, &end);
    if (end == begin || *end != '\0')
      throw ParseFailure(t.line, t.text, std::string("expected a number for ") + what);
    return v;
  }
  int count(const char* what) {
    const Token& t = next(what);
    const char* begin = t.text.c_str();
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(begin, &end, 10);
    if (end == begin || *end != '\0' || errno != 0 || v < 0 || v > 1000000)
      throw ParseFailure(t.line, t.text, std::string("expected a non-negative integer for ") + what);
    return static_cast<int>(v);
  }
  std::string word(const char* what) { return next(what).text; }
  std::vector<double> numbers(const char* key, std::size_t count_expected) {
    keyword(key);
    // dims are read before the blocks: a block cannot hold more numbers than the file has
    // tokens left (checked before allocating: `dims 1000000 0 0` would ask for 8 TB).
    if (count_expected > tokens_.size() - pos_) {
      throw ParseFailure(tokens_[pos_ - 1].line, key,
                         "dims ask for " + std::to_string(count_expected) + " numbers in " + key + ", the file has " +
                             std::to_string(tokens_.size() - pos_) + " tokens left");
    }
    std::vector<double> v(count_expected);
    for (auto& x : v) x = number(key);
    return v;
  }
  bool at_end() const { return pos_ >= tokens_.size(); }
  const Token& peek() const { return tokens_[pos_]; }

 private:
  std::vector<Token> tokens_;
  std::size_t pos_ = 0;
};

bool valid_name(const std::string& name) {
  if (name.empty() || name == "." || name == "..") return false;
  for (const char c : name)
    if (c == '/' || c == '\\' || static_cast<unsigned char>(c) < 0x21) return false;
  return true;
}

// `parse` reads a value of `T` from the cursor over `text`; then the file must say `end` and
// nothing after it. A failure leaves nullopt and sets `error` to "origin:line: what (token '...')".
template <class T, class Parse>
std::optional<T> parse_file(const std::string& text, const std::string& origin, std::string& error, Parse&& parse) {
  Cursor in(tokenize(text));
  try {
    T value = parse(in);
    in.keyword("end");
    if (!in.at_end()) throw ParseFailure(in.peek().line, in.peek().text, "trailing data after 'end'");
    return value;
  } catch (const ParseFailure& f) {
    error = origin + ":" + std::to_string(f.line) + ": " + f.what() + " (token '" + f.token + "')";
    return std::nullopt;
  }
}

// The whole file at `path`; nullopt with `error` set when it cannot be opened.
std::optional<std::string> read_text(const std::string& path, std::string& error) {
  std::ifstream file(path);
  if (!file) {
    error = path + ": cannot open";
    return std::nullopt;
  }
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

}  // namespace

std::optional<Instance> parse_instance(const std::string& text, const std::string& origin, std::string& error) {
  return parse_file<Instance>(text, origin, error, [](Cursor& in) {
    Instance q;
    in.keyword("springbok-qp");
    {
      const Token& v = in.next("version");
      if (v.text != "1") throw ParseFailure(v.line, v.text, "unsupported version (expected 1)");
    }
    in.keyword("name");
    {
      const Token& t = in.next("name");
      if (!valid_name(t.text)) throw ParseFailure(t.line, t.text, "name is not usable as a file name");
      q.name = t.text;
    }
    in.keyword("family");
    q.family = in.word("family");
    in.keyword("dims");
    q.n = in.count("n");
    q.meq = in.count("m_eq");
    q.mi = in.count("m_in");
    const auto n = static_cast<std::size_t>(q.n), meq = static_cast<std::size_t>(q.meq),
               mi = static_cast<std::size_t>(q.mi);
    q.H = in.numbers("H", n * n);
    q.g = in.numbers("g", n);
    q.Aeq = in.numbers("Aeq", meq * n);
    q.beq = in.numbers("beq", meq);
    q.Ain = in.numbers("Ain", mi * n);
    q.lb = in.numbers("lb", mi);
    q.ub = in.numbers("ub", mi);
    in.keyword("expect");
    {
      const Token& t = in.next("expect");
      if (t.text != "optimal" && t.text != "infeasible" && t.text != "error")
        throw ParseFailure(t.line, t.text, "expect must be optimal, infeasible or error");
      q.expect = t.text;
    }
    if (q.expect == "optimal") {
      q.xstar = in.numbers("xstar", n);
      in.keyword("obj");
      q.obj = in.number("obj");
      q.lambda_eq = in.numbers("lambda_eq", meq);
      q.lambda_in = in.numbers("lambda_in", mi);
      in.keyword("active");
      const int k = in.count("active count");
      for (int i = 0; i < k; ++i) {
        const Token& row_token = in.next("active row");
        char* end = nullptr;
        const long row = std::strtol(row_token.text.c_str(), &end, 10);
        if (end == row_token.text.c_str() || *end != '\0' || row < 0 || row >= q.mi)
          throw ParseFailure(row_token.line, row_token.text, "active row out of range");
        const Token& side = in.next("active side");
        if (side.text != "L" && side.text != "U" && side.text != "E")
          throw ParseFailure(side.line, side.text, "active side must be L, U or E");
        q.active.emplace_back(static_cast<int>(row), side.text[0]);
      }
      in.keyword("kkt");
      for (auto& v : q.kkt) v = in.number("kkt");
    }
    return q;
  });
}

std::optional<Instance> read_instance(const std::string& path, std::string& error) {
  const std::optional<std::string> text = read_text(path, error);
  if (!text) return std::nullopt;
  return parse_instance(*text, path, error);
}

const char* status_word(qp::Status status) {
  switch (status) {
    case qp::Status::optimal: return "optimal";
    case qp::Status::infeasible: return "infeasible";
    case qp::Status::maxiter: return "maxiter";
    case qp::Status::bad_input:
    case qp::Status::not_positive_definite:
    case qp::Status::inaccurate: return "error";
  }
  return "error";
}

bool write_solution(const std::string& dir, const Solution& s) {
  const std::string path = dir + "/" + s.name + ".sol";
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return false;
  std::fprintf(f, "springbok-qp-solution 1\nname %s\nstatus %s\n", s.name.c_str(), s.status.c_str());
  if (s.status == "optimal") {
    auto row = [f](const char* key, const std::vector<double>& v) {
      std::fputs(key, f);
      for (const double x : v) std::fprintf(f, " %.17g", x);
      std::fputc('\n', f);
    };
    row("x", s.x);
    row("lambda_eq", s.lambda_eq);
    row("lambda_in", s.lambda_in);
  }
  std::fputs("end\n", f);
  return std::fclose(f) == 0;
}

std::optional<Solution> read_solution(const std::string& path, int n, int meq, int mi, std::string& error) {
  const std::optional<std::string> text = read_text(path, error);
  if (!text) return std::nullopt;
  return parse_file<Solution>(*text, path, error, [&](Cursor& in) {
    Solution s;
    in.keyword("springbok-qp-solution");
    in.keyword("1");
    in.keyword("name");
    s.name = in.word("name");
    in.keyword("status");
    s.status = in.word("status");
    if (s.status == "optimal") {
      s.x = in.numbers("x", static_cast<std::size_t>(n));
      s.lambda_eq = in.numbers("lambda_eq", static_cast<std::size_t>(meq));
      s.lambda_in = in.numbers("lambda_in", static_cast<std::size_t>(mi));
    }
    return s;
  });
}

}  // namespace springbok::qpfile
