// JSON as people read it: indented by two, with every array of plain numbers (or nulls) on one
// line, so a PSD's edges or an impact spectrum's counts are a row each, not a line per number.
// The same document as nlohmann's dump(2) for any parser.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace millsim {

std::string readable_json(const nlohmann::ordered_json& doc);

}  // namespace millsim
