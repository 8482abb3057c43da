// readable_json (io/json_text.h): arrays of numbers on one line, everything else as dump(2),
// and the text parses back to the same document, strings with brackets and escapes included.
#include <gtest/gtest.h>

#include "io/json_text.h"

namespace millsim {
namespace {

TEST(ReadableJson, NumberArraysTakeOneLineAndTheDocumentIsUnchanged) {
  nlohmann::ordered_json doc = {
      {"edges_m", {1e-6, 2.5e-6, -3, 0}}, {"counts", {{0, 1, 2}, {3, 4, 5}}},
      {"sizes", {nullptr, 1.5}},          {"empty", nlohmann::ordered_json::array()},
      {"names", {"a [1, 2]", "b\"]"}},    {"nested", {{"x", {1, 2}}, {"label", "[3,\n 4]"}}}};
  const std::string text = readable_json(doc);
  EXPECT_EQ(nlohmann::ordered_json::parse(text), doc);
  EXPECT_NE(text.find("\"edges_m\": [1e-06, 2.5e-06, -3, 0]"), std::string::npos) << text;
  EXPECT_NE(text.find("[0, 1, 2]"), std::string::npos) << text;
  EXPECT_NE(text.find("\"sizes\": [null, 1.5]"), std::string::npos) << text;
  EXPECT_NE(text.find("\"empty\": []"), std::string::npos) << text;
  // Arrays of strings stay one element per line, as dump(2) writes them.
  EXPECT_NE(text.find("\"names\": [\n"), std::string::npos) << text;
  EXPECT_LT(text.size(), doc.dump(2).size());
}

}  // namespace
}  // namespace millsim
