// springbok::yaml's reader: one set of rules for every YAML input, every problem collected
// with its field path and line.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "springbok/yaml/reader.hpp"

namespace springbok::yaml {
namespace {

// The errors of reading `key` of the one-line document `text` with `read`.
template <class Read>
std::string errors_of(const std::string& text, Read&& read) {
  Errors errors;
  const Field root(YAML::Load(text), "s", errors);
  read(root);
  return errors.joined();
}

TEST(ConfigReader, NumbersAreDecimalFiniteAndInRange) {
  double v = -1.0;
  const auto number = [&](const std::string& text) {
    return errors_of("{x: " + text + "}", [&](const Field& r) { (void)r["x"].number(v, -10.0, 10.0); });
  };
  EXPECT_EQ(number("2.5"), "");
  EXPECT_EQ(v, 2.5);
  EXPECT_EQ(number("+1e-3"), "");
  EXPECT_EQ(v, 1e-3);
  EXPECT_EQ(number("11"), "s.x: must be in [-10, 10], got 11 (line 1)");
  EXPECT_EQ(number(".nan"), "s.x: must be a finite number, got '.nan' (line 1)");
  EXPECT_EQ(number("-.inf"), "s.x: must be a finite number, got '-.inf' (line 1)");
  EXPECT_EQ(number("0x10"), "s.x: must be a number, got '0x10' (line 1)");
  EXPECT_EQ(number("3 m"), "s.x: must be a number, got '3 m' (line 1)");
  EXPECT_EQ(number("[1]"), "s.x: must be a number, got a list (line 1)");
  EXPECT_EQ(number("1e999"), "s.x: must be a number, got '1e999' (line 1)");
  EXPECT_EQ(v, 1e-3) << "a refused value leaves the default";
}

TEST(ConfigReader, IntegersAreDecimalOrHexWithoutAFraction) {
  std::uint32_t id = 7;
  const auto integer = [&](const std::string& text) {
    return errors_of("{id: " + text + "}", [&](const Field& r) { (void)r["id"].integer(id, 0, 0x7FF); });
  };
  EXPECT_EQ(integer("0x6A0"), "");
  EXPECT_EQ(id, 0x6A0u);
  EXPECT_EQ(integer("12"), "");
  EXPECT_EQ(id, 12u);
  EXPECT_EQ(integer("2.0"), "s.id: must be an integer (decimal or 0x hex), got '2.0' (line 1)");
  EXPECT_EQ(integer("0x800"), "s.id: must be in [0, 2047], got 0x800 (line 1)");
  EXPECT_EQ(integer("-1"), "s.id: must be in [0, 2047], got -1 (line 1)");
  EXPECT_EQ(integer("99999999999999999999"),
            "s.id: must be an integer (decimal or 0x hex), got '99999999999999999999' (line 1)");
  EXPECT_EQ(id, 12u);
}

TEST(ConfigReader, BooleansAreTrueOrFalseAndTextIsNotEmpty) {
  bool b = false;
  std::string t = "default";
  EXPECT_EQ(errors_of("{b: true}", [&](const Field& r) { (void)r["b"].boolean(b); }), "");
  EXPECT_TRUE(b);
  EXPECT_EQ(errors_of("{b: yes}", [&](const Field& r) { (void)r["b"].boolean(b); }),
            "s.b: must be true or false, got 'yes' (line 1)");
  EXPECT_EQ(errors_of("{t: ''}", [&](const Field& r) { (void)r["t"].text(t); }), "s.t: must be a non-empty string (line 1)");
  EXPECT_EQ(errors_of("{t: {a: 1}}", [&](const Field& r) { (void)r["t"].text(t); }), "s.t: must be a string, got a map (line 1)");
  EXPECT_EQ(t, "default");
  int c = -1;
  EXPECT_EQ(errors_of("{c: fd5}", [&](const Field& r) { (void)r["c"].choice(c, {"classic7", "fd5"}); }), "");
  EXPECT_EQ(c, 1);
  EXPECT_EQ(errors_of("{c: fd6}", [&](const Field& r) { (void)r["c"].choice(c, {"classic7", "fd5"}); }),
            "s.c: must be one of classic7, fd5, got 'fd6' (line 1)");
}

TEST(ConfigReader, MapsRefuseUnknownAndDuplicatedKeysAndAbsentFieldsKeepTheirDefaults) {
  const std::string text = "a: 1\nb:\n  x: 1\n  y: 2\n  x: 3\n  z: 4\n";
  Errors errors;
  const Field root(YAML::Load(text), "", errors);
  root.allow_only({"a", "b"});
  root["b"].allow_only({"x", "y"});
  double missing = 4.0;
  EXPECT_FALSE(root["c"].number(missing, 0.0, 10.0));
  EXPECT_EQ(missing, 4.0);
  EXPECT_FALSE(root["c"].require());
  EXPECT_EQ(errors.joined(),
            "b.x: duplicate key (line 5)\n"
            "b.z: unknown key (known: x, y) (line 6)\n"
            "c: missing (line 1)");
  // An empty section is a map with every default.
  Errors none;
  const Field empty(YAML::Load("b:\n"), "", none);
  EXPECT_TRUE(empty["b"].allow_only({"x"}));
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(errors_of("[1, 2]", [](const Field& r) { r.allow_only({"x"}); }), "s: must be a map, got a list (line 1)");
}

TEST(ConfigReader, VectorsAndListsNameTheElement) {
  Eigen::Vector3d v(1, 2, 3);
  EXPECT_EQ(errors_of("{v: [1, x, 3]}", [&](const Field& r) { (void)r["v"].vector<3>(v, 0.0, 10.0); }),
            "s.v[1]: must be a number, got 'x' (line 1)");
  EXPECT_EQ(v, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(errors_of("{v: [1, 2]}", [&](const Field& r) { (void)r["v"].vector<3>(v, 0.0, 10.0); }),
            "s.v: must be a list of 3, got 2 elements (line 1)");
  EXPECT_EQ(errors_of("{v: 4}", [&](const Field& r) { (void)r["v"].vector<3>(v, 0.0, 10.0, true); }), "");
  EXPECT_EQ(v, Eigen::Vector3d(4, 4, 4));
}

TEST(ConfigReader, DocumentsFromTextAndFilesNameTheSyntaxErrorsLine) {
  const Document bad = parse_text("a: 1\nb: [1, 2\n");
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.error.find("YAML syntax"), std::string::npos) << bad.error;
  EXPECT_NE(bad.error.find("(line "), std::string::npos) << bad.error;
  const Document missing = parse_file("/nonexistent/springbok.yaml");
  EXPECT_FALSE(missing.ok);
  EXPECT_EQ(missing.error, "/nonexistent/springbok.yaml: cannot open");
  EXPECT_TRUE(parse_text("a: 1").ok);
}

}  // namespace
}  // namespace springbok::yaml
