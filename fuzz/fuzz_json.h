// The fuzz harnesses' shared first step: the input's bytes as untrusted JSON text (the server's
// and the CLI's own parser, with its depth limit). Bytes that are not JSON are an input error,
// one of the allowed outcomes, so the harness stops there.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "core/json_reader.h"

namespace millsim {

inline std::optional<nlohmann::json> fuzz_input_as_json(const std::uint8_t* data,
                                                        std::size_t size) {
  try {
    return parse_untrusted_json(std::string_view(reinterpret_cast<const char*>(data), size));
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;
  } catch (const JsonTooDeep&) {
    return std::nullopt;
  }
}

}  // namespace millsim
