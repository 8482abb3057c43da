#include "core/json_reader.h"

#include <algorithm>
#include <cmath>

namespace millsim {
namespace {

std::string number_text(double v) {
  std::ostringstream out;
  out.precision(6);
  out << v;
  return out.str();
}

// Levenshtein distance, for "did you mean" on unknown keys.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string join_words(const std::vector<std::string>& words) {
  std::string text;
  for (const std::string& w : words) text += (text.empty() ? "" : " ") + w;
  return text;
}

}  // namespace

bool NumberRange::contains(double v) const {
  if (!std::isfinite(v)) return false;
  const bool above_lo = lo_inclusive ? v >= lo : v > lo;
  const bool below_hi = hi_inclusive ? v <= hi : v < hi;
  return above_lo && below_hi;
}

std::string NumberRange::describe(bool integer) const {
  const std::string kind = integer ? "an integer" : "a number";
  const bool no_lo = lo <= -1e308, no_hi = hi >= 1e308;
  if (no_lo && no_hi) return "expected " + kind;
  if (no_hi) return "expected " + kind + (lo_inclusive ? " >= " : " > ") + number_text(lo);
  if (no_lo) return "expected " + kind + (hi_inclusive ? " <= " : " < ") + number_text(hi);
  return "expected " + kind + " in " + (lo_inclusive ? "[" : "(") + number_text(lo) + ", " +
         number_text(hi) + (hi_inclusive ? "]" : ")");
}

std::string json_value_text(const nlohmann::json& value) {
  std::string text = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (text.size() > 80) text = std::string(utf8_prefix(text, 77)) + "...";
  return text;
}

nlohmann::json parse_untrusted_json(std::string_view text) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (in_string) {
      if (c == '\\')
        ++k;  // the escaped character, whatever it is
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth)
        throw JsonTooDeep("arrays and objects nest deeper than " + std::to_string(kMaxJsonDepth) +
                          " levels at byte " + std::to_string(k) + "; at most " +
                          std::to_string(kMaxJsonDepth) + " are allowed");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return nlohmann::json::parse(text);
}

namespace {

// The length of the well-formed UTF-8 character at text[k], or 0 when it is ill-formed.
std::size_t utf8_length(std::string_view text, std::size_t k) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char b = byte(k);
  std::size_t n = b < 0x80           ? 1
                  : (b >> 5) == 0x6  ? 2
                  : (b >> 4) == 0xE  ? 3
                  : (b >> 3) == 0x1E ? 4
                                     : 0;
  if (n == 0 || k + n > text.size()) return 0;
  for (std::size_t i = 1; i < n; ++i)
    if ((byte(k + i) >> 6) != 0x2) return 0;
  if (n == 2 && b < 0xC2) return 0;                          // overlong
  if (n == 3 && b == 0xE0 && byte(k + 1) < 0xA0) return 0;   // overlong
  if (n == 3 && b == 0xED && byte(k + 1) >= 0xA0) return 0;  // surrogates
  if (n == 4 &&
      (b > 0xF4 || (b == 0xF0 && byte(k + 1) < 0x90) || (b == 0xF4 && byte(k + 1) >= 0x90)))
    return 0;  // overlong or past U+10FFFF
  return n;
}

}  // namespace

std::string valid_utf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t k = 0; k < text.size();) {
    const std::size_t n = utf8_length(text, k);
    if (n == 0) {
      out += "\xEF\xBF\xBD";  // U+FFFD
      ++k;
    } else {
      out.append(text.substr(k, n));
      k += n;
    }
  }
  return out;
}

std::string_view utf8_prefix(std::string_view text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return text;
  std::size_t end = max_bytes;
  // Back off past continuation bytes (10xxxxxx) to the start of the cut character.
  while (end > 0 && (static_cast<unsigned char>(text[end]) >> 6) == 0x2) --end;
  return text.substr(0, end);
}

std::string json_pointer_join(const std::string& path, std::string_view key) {
  std::string escaped;
  for (char c : key) {
    if (c == '~')
      escaped += "~0";
    else if (c == '/')
      escaped += "~1";
    else
      escaped += c;
  }
  return path + "/" + escaped;
}

std::string json_pointer_join(const std::string& path, std::size_t index) {
  return path + "/" + std::to_string(index);
}

std::optional<double> read_number(const nlohmann::json& value, const std::string& path,
                                  NumberRange range, InputErrors& errors) {
  if (!value.is_number()) {
    errors.push_back({path, json_value_text(value), range.describe()});
    return std::nullopt;
  }
  const double v = value.get<double>();
  if (!range.contains(v)) {
    errors.push_back({path, json_value_text(value), range.describe()});
    return std::nullopt;
  }
  return v;
}

JsonObjectReader::JsonObjectReader(const nlohmann::json& value, std::string path,
                                   InputErrors& errors)
    : path_(std::move(path)), errors_(errors) {
  if (value.is_object())
    object_ = &value;
  else
    errors_.push_back({path_, json_value_text(value), "expected an object"});
}

const nlohmann::json* JsonObjectReader::find(std::string_view key) {
  known_.emplace_back(key);
  if (!object_) return nullptr;
  auto it = object_->find(std::string(key));
  return it == object_->end() ? nullptr : &*it;
}

bool JsonObjectReader::has(std::string_view key) {
  return find(key) != nullptr;
}

void JsonObjectReader::error(std::string_view key, const nlohmann::json& value,
                             std::string allowed) {
  errors_.push_back({path_of(key), json_value_text(value), std::move(allowed)});
}

double JsonObjectReader::number(std::string_view key, double fallback, NumberRange range) {
  return optional_number(key, range).value_or(fallback);
}

std::optional<double> JsonObjectReader::optional_number(std::string_view key, NumberRange range) {
  const nlohmann::json* v = find(key);
  if (!v) return std::nullopt;
  return read_number(*v, path_of(key), range, errors_);
}

double JsonObjectReader::required_number(std::string_view key, NumberRange range) {
  const nlohmann::json* v = find(key);
  if (!v) {
    if (object_) errors_.push_back({path_of(key), "", "missing; " + range.describe()});
    return 0.0;
  }
  return read_number(*v, path_of(key), range, errors_).value_or(0.0);
}

long long JsonObjectReader::integer(std::string_view key, long long fallback, long long lo,
                                    long long hi) {
  const nlohmann::json* v = find(key);
  if (!v) return fallback;
  const NumberRange range{static_cast<double>(lo), static_cast<double>(hi), true, true};
  const bool integral = v->is_number_integer() ||
                        (v->is_number_float() && std::floor(v->get<double>()) == v->get<double>());
  if (!integral || !range.contains(v->get<double>())) {
    error(key, *v, range.describe(true));
    return fallback;
  }
  return static_cast<long long>(v->get<double>());
}

bool JsonObjectReader::boolean(std::string_view key, bool fallback) {
  const nlohmann::json* v = find(key);
  if (!v) return fallback;
  if (!v->is_boolean()) {
    error(key, *v, "expected true or false");
    return fallback;
  }
  return v->get<bool>();
}

std::string JsonObjectReader::string(std::string_view key, std::string fallback,
                                     const std::vector<std::string>& allowed) {
  const nlohmann::json* v = find(key);
  if (!v) return fallback;
  const std::string expected =
      allowed.empty() ? std::string("expected a string") : "expected one of " + join_words(allowed);
  if (!v->is_string()) {
    error(key, *v, expected);
    return fallback;
  }
  std::string s = v->get<std::string>();
  if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), s) == allowed.end()) {
    error(key, *v, expected);
    return fallback;
  }
  return s;
}

std::string JsonObjectReader::required_string(std::string_view key,
                                              const std::vector<std::string>& allowed) {
  if (object_ && object_->find(std::string(key)) == object_->end()) {
    known_.emplace_back(key);
    errors_.push_back({path_of(key), "",
                       allowed.empty() ? std::string("missing; expected a string")
                                       : "missing; expected one of " + join_words(allowed)});
    return {};
  }
  return string(key, {}, allowed);
}

std::optional<Vec3> JsonObjectReader::optional_vec3(std::string_view key, NumberRange range) {
  const nlohmann::json* v = find(key);
  if (!v) return std::nullopt;
  if (!v->is_array() || v->size() != 3) {
    error(key, *v, "expected an array of 3 numbers");
    return std::nullopt;
  }
  Vec3 out;
  bool ok = true;
  for (int axis = 0; axis < 3; ++axis) {
    auto c =
        read_number((*v)[axis], json_pointer_join(path_of(key), std::size_t(axis)), range, errors_);
    if (c)
      out[axis] = *c;
    else
      ok = false;
  }
  return ok ? std::optional<Vec3>(out) : std::nullopt;
}

Vec3 JsonObjectReader::vec3(std::string_view key, Vec3 fallback, NumberRange range) {
  return optional_vec3(key, range).value_or(fallback);
}

std::array<bool, 3> JsonObjectReader::bool3(std::string_view key, std::array<bool, 3> fallback) {
  const nlohmann::json* v = find(key);
  if (!v) return fallback;
  const bool ok = v->is_array() && v->size() == 3 &&
                  std::all_of(v->begin(), v->end(), [](const auto& b) { return b.is_boolean(); });
  if (!ok) {
    error(key, *v, "expected an array of 3 booleans (x, y, z)");
    return fallback;
  }
  return {(*v)[0].get<bool>(), (*v)[1].get<bool>(), (*v)[2].get<bool>()};
}

const nlohmann::json* JsonObjectReader::child(std::string_view key) {
  return find(key);
}

const nlohmann::json* JsonObjectReader::array(std::string_view key) {
  const nlohmann::json* v = find(key);
  if (v && !v->is_array()) {
    error(key, *v, "expected an array");
    return nullptr;
  }
  return v;
}

void JsonObjectReader::finish() {
  if (!object_) return;
  std::vector<std::string> known = known_;
  std::sort(known.begin(), known.end());
  known.erase(std::unique(known.begin(), known.end()), known.end());
  for (const auto& [key, value] : object_->items()) {
    if (std::binary_search(known.begin(), known.end(), key)) continue;
    std::string hint;
    std::size_t best = 3;
    for (const std::string& k : known) {
      const std::size_t d = edit_distance(key, k);
      if (d < best) best = d, hint = k;
    }
    std::string allowed = "unknown key";
    if (!hint.empty()) allowed += " (did you mean \"" + hint + "\"?)";
    allowed += "; known: " + join_words(known);
    errors_.push_back({json_pointer_join(path_, key), "", allowed});
  }
}

}  // namespace millsim
