// A minimal SVG line/scatter plot writer (no dependencies): one or more panels, each with axes,
// ticks, labels and any number of named series. Used by report programs (bench/) and, later,
// by the service's error-against-run-time plot.
#pragma once

#include <string>
#include <vector>

namespace millsim {

struct PlotSeries {
  std::string name;
  std::vector<double> x, y;
  std::string color = "#1f77b4";
  bool line = true;                 // connect the points
  bool markers = true;              // draw a circle at each point
  std::vector<std::string> labels;  // optional text beside each point
  bool hollow = false;              // markers as rings (e.g. the reference)
};

struct PlotPanel {
  std::string title;
  std::string x_label, y_label;
  std::vector<PlotSeries> series;
  bool log_x = false, log_y = false;
  std::vector<std::string> notes;  // lines printed under the panel (e.g. what each label means)
};

// Panels are laid out side by side. The legend sits in a row above the plot area, so it never
// covers data; notes go below the x label. Returns the SVG document.
std::string render_svg(const std::vector<PlotPanel>& panels, int panel_width = 480,
                       int panel_height = 360);

}  // namespace millsim
