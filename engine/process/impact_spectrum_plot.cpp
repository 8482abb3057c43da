#include "process/impact_spectrum_plot.h"

#include <cmath>

#include "io/svg_plot.h"

namespace millsim {

std::string impact_spectrum_svg(const nlohmann::json& spectrum, const std::string& title) {
  static const char* const kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                        "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};
  const std::vector<double> edges = spectrum.value("energy_edges_j_per_kg", std::vector<double>{});
  const double seconds = spectrum.value("simulated_time_s", 0.0);
  if (edges.size() < 2 || !(seconds > 0.0) || !spectrum.contains("groups")) return "";
  PlotPanel normal, tangential;
  normal.title = title + ": normal impact energy";
  tangential.title = title + ": tangential impact energy";
  for (PlotPanel* p : {&normal, &tangential}) {
    p->x_label = "specific impact energy v^2/2 (J/kg, log scale)";
    p->y_label = "impacts per second in the bin (log scale)";
    p->log_x = p->log_y = true;
  }
  bool any = false;
  std::size_t color = 0;
  for (const nlohmann::json& group : spectrum["groups"]) {
    for (const auto& [panel, key] : {std::pair<PlotPanel*, const char*>{&normal, "normal_counts"},
                                     {&tangential, "tangential_counts"}}) {
      PlotSeries s;
      s.name = group.value("name", std::string("group"));
      s.color = kColors[color % std::size(kColors)];
      s.markers = false;
      for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
        double count = 0.0;
        for (const nlohmann::json& row : group.value(key, nlohmann::json::array()))
          if (b < row.size() && row[b].is_number()) count += row[b].get<double>();
        if (count <= 0.0) continue;
        s.x.push_back(std::sqrt(edges[b] * edges[b + 1]));  // the bin's geometric centre
        s.y.push_back(count / seconds);
      }
      any = any || !s.x.empty();
      if (!s.x.empty()) panel->series.push_back(std::move(s));
    }
    ++color;
  }
  if (!any) return "";
  normal.notes.push_back("a pair impact counts once for each of its two particles");
  return render_svg({normal, tangential}, 520, 380);
}

}  // namespace millsim
