// impact_spectrum.svg: a run's impact-energy spectrum as result.json's `impact_spectrum` holds it
// (sim/run.cpp), drawn as impacts per second in each energy bin against specific energy, one
// curve per contact group (summed over the size classes), the normal energy in the left panel
// and the tangential in the right. The engine writes it beside result.json; the service draws
// the same from a stored result (GET /v1/runs/{id}/plot/impact-spectrum).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace millsim {

// Empty when the section holds no impact (nothing to draw on log axes).
std::string impact_spectrum_svg(const nlohmann::json& spectrum, const std::string& title);

}  // namespace millsim
