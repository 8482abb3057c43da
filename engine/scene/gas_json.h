// Reads and validates the scene's `gas` section into a GasConfig (gas/gas_config.h); each key
// is documented in docs/scene-format.md ("gas") and the physics in docs/gas.md.
#pragma once

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "gas/gas_config.h"
#include "scene/scene_config.h"

namespace millsim {

// Reads an inflow schedule, {"time_s": [...], "speed_m_per_s": [...]} or {"time_s": [...],
// "mass_flow_kg_per_s": [...]} (docs/scene-format.md): rows in non-decreasing time, 1 to 10000.
InflowSchedule parse_inflow_schedule(const nlohmann::json& value, const std::string& path,
                                     InputErrors& errors);

GasConfig parse_gas(const nlohmann::json& value, const DomainConfig& domain, InputErrors& errors);
// Gas blown in needs an outlet: checked once every section that adds patches has (a mill's
// vortex finder is an outlet of the gas).
void check_gas_outflow(const GasConfig& gas, InputErrors& errors);

// The compressible model: a supply pressure (at `path`) must exceed the chamber's, its initial
// pressure and every outlet's; an error naming both otherwise.
void check_supply_pressure(const GasConfig& gas, const std::string& path, double supply_pa,
                           InputErrors& errors);

}  // namespace millsim
