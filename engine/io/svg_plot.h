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
  bool line = true;     // connect the points
  bool markers = true;  // draw a circle at each point
};

struct PlotPanel {
  std::string title;
  std::string x_label, y_label;
  std::vector<PlotSeries> series;
  bool log_x = false, log_y = false;
};

// Panels are laid out side by side. Returns the SVG document.
std::string render_svg(const std::vector<PlotPanel>& panels, int panel_width = 480,
                       int panel_height = 360);

}  // namespace millsim
