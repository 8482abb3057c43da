#include "io/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace millsim {
namespace {

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

struct Axis {
  double lo, hi;
  bool log;
  double map(double v, double pixel_lo, double pixel_hi) const {
    const double a = log ? std::log10(lo) : lo, b = log ? std::log10(hi) : hi;
    const double t = ((log ? std::log10(v) : v) - a) / (b - a);
    return pixel_lo + t * (pixel_hi - pixel_lo);
  }
  std::vector<double> ticks() const {
    std::vector<double> out;
    if (log) {
      // Decades, with 2 and 5 between them while that gives no more than eight ticks.
      std::vector<double> decades, fine;
      for (double p = std::floor(std::log10(lo)); p <= std::ceil(std::log10(hi)); ++p)
        for (double m : {1.0, 2.0, 5.0}) {
          const double v = m * std::pow(10.0, p);
          if (v < lo * 0.999 || v > hi * 1.001) continue;
          fine.push_back(v);
          if (m == 1.0) decades.push_back(v);
        }
      if (fine.size() >= 2 && fine.size() <= 8) return fine;
      if (decades.size() >= 2) return decades;
      if (fine.size() >= 2) return fine;
    }
    const double span = hi - lo, raw = span / 5.0;
    const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
    double step = magnitude;
    for (double m : {1.0, 2.0, 5.0, 10.0})
      if (m * magnitude >= raw) {
        step = m * magnitude;
        break;
      }
    for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) out.push_back(v);
    return out;
  }
};

Axis fit_axis(const std::vector<PlotSeries>& series, bool use_x, bool log) {
  double lo = 1e300, hi = -1e300;
  for (const PlotSeries& s : series)
    for (double v : use_x ? s.x : s.y)
      if (std::isfinite(v) && (!log || v > 0)) lo = std::min(lo, v), hi = std::max(hi, v);
  if (lo > hi) lo = 0, hi = 1;
  if (lo == hi) {
    const double pad = lo == 0 ? 1.0 : 0.1 * std::abs(lo);
    lo -= pad, hi += pad;
  } else if (!log) {
    const double pad = 0.05 * (hi - lo);
    lo -= pad, hi += pad;
  } else {
    lo /= 1.2, hi *= 1.2;
  }
  return {lo, hi, log};
}

// A tick value as text; `span` is the axis range, so rounding noise next to zero prints "0"
// (not "-0" or "1e-17").
std::string tick_text(double v, double span) {
  if (std::abs(v) < 1e-9 * span) v = 0.0;
  std::ostringstream out;
  out.precision(3);
  out << v;
  return out.str();
}

// Where each series' legend entry goes: entries flow left to right in rows above the plot, each
// as wide as its text (about 7 px a character). Returns x and row per series.
std::vector<std::pair<double, int>> legend_layout(const PlotPanel& panel, double left,
                                                  double right) {
  std::vector<std::pair<double, int>> at;
  double x = left;
  int row = 0;
  for (const PlotSeries& series : panel.series) {
    const double entry = 36.0 + 7.0 * double(series.name.size());
    if (x > left && x + entry > right) x = left, ++row;
    at.emplace_back(x, row);
    x += entry;
  }
  return at;
}

int legend_rows(const std::vector<std::pair<double, int>>& at) {
  return at.empty() ? 0 : at.back().second;
}

}  // namespace

std::string render_svg(const std::vector<PlotPanel>& panels, int w, int plot_h) {
  std::ostringstream svg;
  const int width = w * int(panels.size());
  std::size_t most_notes = 0;
  int extra_rows = 0;  // legend rows past the first, in the panel that has most
  for (std::size_t k = 0; k < panels.size(); ++k) {
    most_notes = std::max(most_notes, panels[k].notes.size());
    extra_rows =
        std::max(extra_rows,
                 legend_rows(legend_layout(panels[k], double(k) * w + 70, double(k + 1) * w - 20)));
  }
  const int h = plot_h + 16 * int(most_notes) + 16 * extra_rows;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << h
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const PlotPanel& panel = panels[k];
    const double left = double(k) * w + 70, right = double(k + 1) * w - 20;
    // The plot starts below the legend's last row.
    const std::vector<std::pair<double, int>> legend_at = legend_layout(panel, left, right);
    const int rows = legend_rows(legend_at);
    const double top = 56 + 16.0 * rows, bottom = plot_h - 50 + 16.0 * rows;
    const Axis ax = fit_axis(panel.series, true, panel.log_x);
    const Axis ay = fit_axis(panel.series, false, panel.log_y);
    svg << "<text x=\"" << (left + right) / 2
        << "\" y=\"22\" text-anchor=\"middle\" font-size=\"14\">" << escape(panel.title)
        << "</text>\n";
    svg << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << right - left
        << "\" height=\"" << bottom - top << "\" fill=\"none\" stroke=\"black\"/>\n";
    for (double t : ax.ticks()) {
      const double x = ax.map(t, left, right);
      svg << "<line x1=\"" << x << "\" y1=\"" << bottom << "\" x2=\"" << x << "\" y2=\""
          << bottom + 5 << "\" stroke=\"black\"/><text x=\"" << x << "\" y=\"" << bottom + 18
          << "\" text-anchor=\"middle\">" << tick_text(t, ax.hi - ax.lo) << "</text>\n";
    }
    for (double t : ay.ticks()) {
      const double y = ay.map(t, bottom, top);
      svg << "<line x1=\"" << left - 5 << "\" y1=\"" << y << "\" x2=\"" << left << "\" y2=\"" << y
          << "\" stroke=\"black\"/><text x=\"" << left - 8 << "\" y=\"" << y + 4
          << "\" text-anchor=\"end\">" << tick_text(t, ay.hi - ay.lo) << "</text>\n";
    }
    svg << "<text x=\"" << (left + right) / 2 << "\" y=\"" << plot_h - 12 + 16 * rows
        << "\" text-anchor=\"middle\">" << escape(panel.x_label) << "</text>\n";
    for (std::size_t n = 0; n < panel.notes.size(); ++n)
      svg << "<text x=\"" << double(k) * w + 16 << "\" y=\""
          << plot_h + 4 + 16 * double(n + std::size_t(rows)) << "\" font-size=\"11\">"
          << escape(panel.notes[n]) << "</text>\n";
    svg << "<text transform=\"translate(" << double(k) * w + 16 << "," << (top + bottom) / 2
        << ") rotate(-90)\" text-anchor=\"middle\">" << escape(panel.y_label) << "</text>\n";
    for (std::size_t s = 0; s < panel.series.size(); ++s) {
      const PlotSeries& series = panel.series[s];
      std::ostringstream points;
      for (std::size_t i = 0; i < series.x.size(); ++i)
        points << ax.map(series.x[i], left, right) << "," << ay.map(series.y[i], bottom, top)
               << " ";
      if (series.line)
        svg << "<polyline fill=\"none\" stroke=\"" << series.color
            << "\" stroke-width=\"2\" points=\"" << points.str() << "\"/>\n";
      if (series.markers)
        for (std::size_t i = 0; i < series.x.size(); ++i)
          svg << "<circle cx=\"" << ax.map(series.x[i], left, right) << "\" cy=\""
              << ay.map(series.y[i], bottom, top) << "\" r=\"" << (series.hollow ? 5 : 3)
              << "\" fill=\"" << (series.hollow ? "none" : series.color) << "\" stroke=\""
              << series.color << "\" stroke-width=\"1.5\"/>\n";
      for (std::size_t i = 0; i < series.labels.size() && i < series.x.size(); ++i)
        svg << "<text x=\"" << ax.map(series.x[i], left, right) + 6 << "\" y=\""
            << ay.map(series.y[i], bottom, top) - 6 << "\" font-size=\"11\" fill=\"#333\">"
            << escape(series.labels[i]) << "</text>\n";
      // The legend entry, in its row above the plot area.
      const double lx = legend_at[s].first, ly = 48 + 16.0 * legend_at[s].second;
      svg << "<line x1=\"" << lx << "\" y1=\"" << ly - 4 << "\" x2=\"" << lx + 20 << "\" y2=\""
          << ly - 4 << "\" stroke=\"" << series.color << "\" stroke-width=\"2\"/><text x=\""
          << lx + 26 << "\" y=\"" << ly << "\">" << escape(series.name) << "</text>\n";
    }
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace millsim
