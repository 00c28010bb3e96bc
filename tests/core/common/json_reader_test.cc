#include "core/common/json_reader.h"

#include <gtest/gtest.h>

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
