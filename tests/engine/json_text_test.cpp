// Text from outside: nesting measured before parsing (brackets inside strings and escaped quotes
// do not count), ill-formed UTF-8 replaced by U+FFFD sequence by sequence per the Unicode
// standard's table of well-formed byte sequences, and cuts made at character boundaries.
#include <gtest/gtest.h>

#include "core/json_reader.h"

namespace millsim {
namespace {

const std::string kReplacement = "\xEF\xBF\xBD";

TEST(JsonText, NestingIsLimitedAndStringsDoNotCount) {
  const auto nested = [](int depth) {
    return std::string(std::size_t(depth), '[') + std::string(std::size_t(depth), ']');
  };
  EXPECT_NO_THROW(parse_untrusted_json(nested(kMaxJsonDepth)));
  EXPECT_THROW(parse_untrusted_json(nested(kMaxJsonDepth + 1)), JsonTooDeep);
  // A thousand brackets inside a string, and an escaped quote before them: one level.
  const std::string in_string = "[\"\\\"" + std::string(1000, '[') + "\"]";
  EXPECT_EQ(parse_untrusted_json(in_string)[0].get<std::string>().size(), 1001u);
  EXPECT_THROW(parse_untrusted_json("[\"\xff\"]"), nlohmann::json::exception);  // not UTF-8
}

TEST(JsonText, IllFormedUtf8IsReplacedAndWellFormedKept) {
  const std::string good = "a\xC3\xA9\xE2\x82\xAC\xF0\x9F\x98\x80z";  // a é € 😀 z
  EXPECT_EQ(valid_utf8(good), good);
  EXPECT_EQ(valid_utf8("\x80"), kReplacement);                     // lone continuation
  EXPECT_EQ(valid_utf8("\xC0\x80"), kReplacement + kReplacement);  // overlong NUL
  EXPECT_EQ(valid_utf8("\xED\xA0\x80"), kReplacement + kReplacement + kReplacement);  // surrogate
  EXPECT_EQ(valid_utf8("x\xE2\x82"), "x" + kReplacement + kReplacement);  // cut short at the end
  EXPECT_EQ(valid_utf8("\xF4\x90\x80\x80").substr(0, 3), kReplacement);   // past U+10FFFF
  // What comes out always goes into JSON.
  EXPECT_NO_THROW(nlohmann::json(valid_utf8("\xff\xfe ok \xC3")).dump());
}

TEST(JsonText, CutsFallBetweenCharacters) {
  const std::string text =
      "a\xC3\xA9"
      "b";                               // a é b
  EXPECT_EQ(utf8_prefix(text, 2), "a");  // not half of é
  EXPECT_EQ(utf8_prefix(text, 3), "a\xC3\xA9");
  EXPECT_EQ(utf8_prefix(text, 10), text);
  EXPECT_EQ(utf8_prefix("\xE2\x82\xAC", 2), "");
}

}  // namespace
}  // namespace millsim
