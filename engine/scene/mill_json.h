// Reads and validates the scene's `mill` section into a MillConfig (geometry/mill_config.h), and
// checks it against the rest of the scene (domain, feeds, sources, gas grid); each key is
// documented in docs/scene-format.md ("mill").
#pragma once

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "scene/scene_config.h"

namespace millsim {

// `gas`: the scene's gas section when it has one (its model decides what a nozzle may be set by).
MillConfig parse_mill(const nlohmann::json& value, const DomainConfig& domain,
                      const std::vector<MaterialConfig>& materials, const GasConfig* gas,
                      InputErrors& errors);

// Cross-checks a parsed scene with a mill: no periodic axis, feed and source regions inside the
// chamber, an outlet wide enough for the gas grid; then adds the mill's outlet to the scene's
// outlets and its solids, jets and outlet patch to the gas config.
void finish_mill_scene(SceneConfig& scene, InputErrors& errors);

}  // namespace millsim
