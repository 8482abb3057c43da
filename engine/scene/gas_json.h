// Reads and validates the scene's `gas` section into a GasConfig (gas/gas_config.h); each key
// is documented in docs/scene-format.md ("gas") and the physics in docs/gas.md.
#pragma once

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "gas/gas_config.h"
#include "scene/scene_config.h"

namespace millsim {

GasConfig parse_gas(const nlohmann::json& value, const DomainConfig& domain, InputErrors& errors);

}  // namespace millsim
