// report_springs: regenerates the comparison of the paper's Fig. 7 (normal stiffness) and
// Fig. 8 (normal damper) for a 30 µm particle against partners of 10–100 µm with the Table 1
// properties (E = 1 GPa, ν = 0.3, ρ = 2000 kg/m³, e = 0.5): the engine's per-particle series
// springs (§3.2, Eq. 2) against the customary mean-property model (Eq. 1). Prints a Markdown
// table and writes an SVG plot.
//
//   report_springs [--svg FILE]   (default FILE: springs_fig7_fig8.svg)
#include <cstdio>
#include <fstream>
#include <string>

#include "contact/contact_law.h"
#include "io/svg_plot.h"
#include "scene/scene_config.h"

int main(int argc, char** argv) {
  using namespace millsim;
  std::string svg_path = "springs_fig7_fig8.svg";
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--svg" && k + 1 < argc)
      svg_path = argv[++k];
    else {
      std::fprintf(stderr, "usage: report_springs [--svg FILE]\n");
      return 2;
    }
  }
  SceneConfig scene;
  scene.materials.push_back({"table1", 1e9, 0.3, 2000.0, 0.5, 0.0, 0.0, false, {}});
  const MaterialTable table(scene);
  PlotSeries k_series, k_mean;
  k_series.name = "series (Eq. 2)", k_series.color = "#d62728";
  k_mean.name = "mean properties (Eq. 1)", k_mean.color = "#1f77b4";
  PlotSeries eta_series = k_series, eta_mean = k_mean;
  std::printf(
      "| partner d (µm) | k_n series (N/m^1.5) | k_n mean (N/m^1.5) | ratio | η_n series (N "
      "s/m^1.25) | η_n mean (N s/m^1.25) | ratio |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- |\n");
  for (double d_um = 10.0; d_um <= 100.0 + 1e-9; d_um += 5.0) {
    ParticleStore p;
    p.add(table, 0, 1, {}, {}, {}, 30e-6);
    p.add(table, 0, 2, {1, 0, 0}, {}, {}, d_um * 1e-6);
    const PairSprings series = SeriesSprings(p)(0, 1, table.pair(0, 0));
    const PairSprings mean = EquivalentProperties(p)(0, 1, table.pair(0, 0));
    std::printf("| %.0f | %.4e | %.4e | %.4f | %.4e | %.4e | %.4f |\n", d_um,
                series.normal_stiffness, mean.normal_stiffness,
                series.normal_stiffness / mean.normal_stiffness, series.normal_damping,
                mean.normal_damping, series.normal_damping / mean.normal_damping);
    for (auto* s : {&k_series, &k_mean, &eta_series, &eta_mean}) s->x.push_back(d_um);
    k_series.y.push_back(series.normal_stiffness);
    k_mean.y.push_back(mean.normal_stiffness);
    eta_series.y.push_back(series.normal_damping);
    eta_mean.y.push_back(mean.normal_damping);
  }
  std::vector<PlotPanel> panels(2);
  panels[0].title = "Fig. 7: normal stiffness, 30 µm particle";
  panels[0].y_label = "k_n (N/m^1.5)";
  panels[0].series = {k_series, k_mean};
  panels[1].title = "Fig. 8: normal damper, 30 µm particle";
  panels[1].y_label = "η_n (N s/m^1.25)";
  panels[1].series = {eta_series, eta_mean};
  for (PlotPanel& panel : panels) panel.x_label = "partner diameter (µm)";
  std::ofstream(svg_path) << render_svg(panels);
  std::printf("\nplot written to %s\n", svg_path.c_str());
  return 0;
}
