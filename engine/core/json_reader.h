// JsonObjectReader: reads the fields of one JSON object with types, ranges and defaults, and
// collects every problem as an InputError (JSON-pointer path, value, what is allowed) instead of
// stopping at the first. Every key it is asked about counts as known; finish() then reports the
// keys nobody asked for, listing the known ones (and a near miss, "did you mean").
// Used by the scene loader and, later, by study files and HTTP bodies.
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/errors.h"
#include "core/vec3.h"

namespace millsim {

// A closed/open interval for numeric fields; describe() gives the text used in messages.
struct NumberRange {
  double lo = -1e308;
  double hi = 1e308;
  bool lo_inclusive = true;
  bool hi_inclusive = true;

  bool contains(double v) const;
  std::string describe(bool integer = false) const;

  static NumberRange any() { return {}; }
  static NumberRange positive() { return {0.0, 1e308, false, true}; }
  static NumberRange non_negative() { return {0.0, 1e308, true, true}; }
  static NumberRange closed(double lo, double hi) { return {lo, hi, true, true}; }
  static NumberRange open_closed(double lo, double hi) { return {lo, hi, false, true}; }
  static NumberRange open(double lo, double hi) { return {lo, hi, false, false}; }
};

std::string json_value_text(const nlohmann::json& value);

// Documents from outside (scene, study and suite files, request bodies) may nest their arrays and
// objects at most this deep; the scene format itself needs 5.
inline constexpr int kMaxJsonDepth = 64;

struct JsonTooDeep : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Parses a document from outside. Its nesting is measured first, by a scan without recursion, so
// no input can exhaust the stack here or in anything that walks the document later. Throws
// JsonTooDeep past kMaxJsonDepth (the message names the byte and the limit), or
// nlohmann::json::exception when the text is not JSON (ill-formed UTF-8 in a string included).
nlohmann::json parse_untrusted_json(std::string_view text);

// Text from outside that is not JSON (particle files, logs, other programs' messages): the same
// text with every ill-formed UTF-8 sequence replaced by U+FFFD, so it can go into JSON.
std::string valid_utf8(std::string_view text);

// The longest prefix of `text` of at most `max_bytes` that does not cut a UTF-8 character.
std::string_view utf8_prefix(std::string_view text, std::size_t max_bytes);
std::string json_pointer_join(const std::string& path, std::string_view key);
std::string json_pointer_join(const std::string& path, std::size_t index);

class JsonObjectReader {
 public:
  // Reports an error (and reads nothing) when `value` is not an object.
  JsonObjectReader(const nlohmann::json& value, std::string path, InputErrors& errors);

  bool is_object() const { return object_ != nullptr; }
  bool has(std::string_view key);  // marks the key known
  const std::string& path() const { return path_; }
  std::string path_of(std::string_view key) const { return json_pointer_join(path_, key); }

  double number(std::string_view key, double fallback, NumberRange range);
  std::optional<double> optional_number(std::string_view key, NumberRange range);
  double required_number(std::string_view key, NumberRange range);
  long long integer(std::string_view key, long long fallback, long long lo, long long hi);
  bool boolean(std::string_view key, bool fallback);
  std::string string(std::string_view key, std::string fallback,
                     const std::vector<std::string>& allowed = {});
  std::string required_string(std::string_view key, const std::vector<std::string>& allowed = {});
  Vec3 vec3(std::string_view key, Vec3 fallback, NumberRange range = NumberRange::any());
  std::optional<Vec3> optional_vec3(std::string_view key, NumberRange range = NumberRange::any());
  std::array<bool, 3> bool3(std::string_view key, std::array<bool, 3> fallback);

  // The raw child (marked known), or nullptr when absent. Type is checked by the caller.
  const nlohmann::json* child(std::string_view key);
  // Like child(), but reports an error unless it is an array (absent is fine).
  const nlohmann::json* array(std::string_view key);

  // Reports every key not asked about. Call once, after all reads.
  void finish();

  void error(std::string_view key, const nlohmann::json& value, std::string allowed);

 private:
  const nlohmann::json* find(std::string_view key);

  const nlohmann::json* object_ = nullptr;
  std::string path_;
  InputErrors& errors_;
  std::vector<std::string> known_;
};

// Reads a number element (not a keyed field) with a range check.
std::optional<double> read_number(const nlohmann::json& value, const std::string& path,
                                  NumberRange range, InputErrors& errors);

}  // namespace millsim
