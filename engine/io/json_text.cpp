#include "io/json_text.h"

#include <cstring>

namespace millsim {
namespace {

// A character an array of numbers and nulls is made of, besides its whitespace.
bool number_array_char(char c) {
  return (c >= '0' && c <= '9') || std::strchr("+-.eE,nul", c) != nullptr;
}

}  // namespace

std::string readable_json(const nlohmann::ordered_json& doc) {
  const std::string text = doc.dump(2);
  std::string out;
  out.reserve(text.size());
  bool in_string = false;
  for (std::size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (in_string) {
      out += c;
      if (c == '\\' && k + 1 < text.size())
        out += text[++k];  // an escaped character
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    if (c != '[') {
      out += c;
      continue;
    }
    // An array: collapsed when it holds numbers and nulls only (a leaf: no string, object or
    // array inside).
    std::size_t end = k + 1;
    bool plain = true;
    for (; end < text.size() && text[end] != ']'; ++end)
      if (!number_array_char(text[end]) && text[end] != ' ' && text[end] != '\n') {
        plain = false;
        break;
      }
    if (!plain || end >= text.size()) {
      out += c;
      continue;
    }
    out += '[';
    bool space = false;
    for (std::size_t j = k + 1; j < end; ++j) {
      const char a = text[j];
      if (a == ' ' || a == '\n') {
        space = true;
        continue;
      }
      if (space && out.back() == ',') out += ' ';
      space = false;
      out += a;
    }
    out += ']';
    k = end;
  }
  return out;
}

}  // namespace millsim
