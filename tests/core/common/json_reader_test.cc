#include "core/common/json_reader.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <fstream>

namespace sweepscan {
namespace {

TEST(JsonReaderTest, ReportsPathAndReason) {
  const nlohmann::json j = nlohmann::json::parse(R"({"a": {"b": -1, "s": "x", "n": 3}})");
  const JsonObject root(j, "");
  const JsonObject a = root.Object("a");
  try {
    a.Positive("b");
    FAIL();
  } catch (const JsonError& e) {
    EXPECT_STREQ(e.what(), "a.b: must be > 0, got -1");
  }
  try {
    a.Number("s");
    FAIL();
  } catch (const JsonError& e) {
    EXPECT_STREQ(e.what(), "a.s: expected a number, got a string");
  }
  try {
    a.Number("missing");
    FAIL();
  } catch (const JsonError& e) {
    EXPECT_STREQ(e.what(), "a.missing: missing");
  }
  EXPECT_EQ(a.Integer("n"), 3);
  EXPECT_THROW(a.AllowOnly({"b", "s"}), JsonError);
}

// Strict means no silent choice: a key twice in one object (the parser
// kept the last), and an integer beyond int64 (it wrapped to -1), are
// refused with the file and the key. The same key in two objects is fine.
TEST(JsonReaderTest, DuplicateKeysAndIntegersBeyondInt64AreRefused) {
  nlohmann::json j;
  Status s = ParseJson(R"({"m": {"gamma": 0.0, "beta": 1, "gamma": 0.0355}})", "c.json", &j);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message(),
            "c.json: not a file of ours (the key 'gamma' appears twice in one object)");
  EXPECT_TRUE(ParseJson(R"({"a": {"x": 1}, "b": {"x": 2}, "c": [{"x": 3}, {"x": 4}], "x": 5})",
                        "d.json", &j)
                  .ok());
  ASSERT_TRUE(
      ParseJson(R"({"v": 18446744073709551615, "w": 9223372036854775807})", "e.json", &j).ok());
  const JsonObject root(j, "");
  EXPECT_EQ(root.Integer("w"), INT64_MAX);
  try {
    root.Integer("v");
    FAIL();
  } catch (const JsonError& e) {
    EXPECT_STREQ(e.what(), "v: out of range, got 18446744073709551615");
  }
}

TEST(JsonReaderTest, SyntaxErrorsGiveLineAndColumn) {
  nlohmann::json j;
  const Status s = ParseJson("{\n  \"a\": 1,\n  \"b\": NaN\n}", "f.json", &j);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message().rfind("f.json:3:", 0), 0u) << s.message();
  // A number outside double range is refused, not thrown.
  EXPECT_FALSE(ParseJson("{\"a\": 1e999}", "g.json", &j).ok());
}

TEST(JsonReaderTest, AtomicWriteReplacesWholeFile) {
  const std::string path = ::testing::TempDir() + "/sweepscan_atomic.json";
  ASSERT_TRUE(WriteFileAtomically(path, std::string(10000, 'a')).ok());
  ASSERT_TRUE(WriteFileAtomically(path, "short").ok());
  std::ifstream in(path);
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content, "short");
  EXPECT_FALSE(WriteFileAtomically("/dev/null/f.json", "x").ok());
  std::remove(path.c_str());
}

// A meta.json nested 200 000 deep under "settings" crashed every reader
// (copying it recursed once a level); it is refused, and a file nested as
// deep as ours are is not.
TEST(JsonReaderTest, ValuesNestedBeyondAnyFileOfOursAreRefused) {
  nlohmann::json j;
  std::string deep = "{\"settings\": " + std::string(200000, '[') + std::string(200000, ']') + "}";
  Status s = ParseJson(deep, "meta.json", &j);
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "meta.json: not a file of ours (values nested more than 64 deep)");
  const std::string fine = "{\"a\": " + std::string(60, '[') + std::string(60, ']') + "}";
  EXPECT_TRUE(ParseJson(fine, "x.json", &j).ok());
}

}  // namespace
}  // namespace sweepscan
