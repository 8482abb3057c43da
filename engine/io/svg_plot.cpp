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
      for (double p = std::floor(std::log10(lo)); p <= std::ceil(std::log10(hi)); ++p) {
        const double v = std::pow(10.0, p);
        if (v >= lo * 0.999 && v <= hi * 1.001) out.push_back(v);
      }
      if (out.size() >= 2) return out;
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

std::string tick_text(double v) {
  std::ostringstream out;
  out.precision(3);
  out << v;
  return out.str();
}

}  // namespace

std::string render_svg(const std::vector<PlotPanel>& panels, int w, int h) {
  std::ostringstream svg;
  const int width = w * int(panels.size());
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << h
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const PlotPanel& panel = panels[k];
    const double left = double(k) * w + 70, right = double(k + 1) * w - 20, top = 40,
                 bottom = h - 50;
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
          << "\" text-anchor=\"middle\">" << tick_text(t) << "</text>\n";
    }
    for (double t : ay.ticks()) {
      const double y = ay.map(t, bottom, top);
      svg << "<line x1=\"" << left - 5 << "\" y1=\"" << y << "\" x2=\"" << left << "\" y2=\"" << y
          << "\" stroke=\"black\"/><text x=\"" << left - 8 << "\" y=\"" << y + 4
          << "\" text-anchor=\"end\">" << tick_text(t) << "</text>\n";
    }
    svg << "<text x=\"" << (left + right) / 2 << "\" y=\"" << h - 12 << "\" text-anchor=\"middle\">"
        << escape(panel.x_label) << "</text>\n";
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
              << ay.map(series.y[i], bottom, top) << "\" r=\"3\" fill=\"" << series.color
              << "\"/>\n";
      const double ly = top + 16 + 16 * double(s);
      svg << "<line x1=\"" << left + 10 << "\" y1=\"" << ly - 4 << "\" x2=\"" << left + 30
          << "\" y2=\"" << ly - 4 << "\" stroke=\"" << series.color
          << "\" stroke-width=\"2\"/><text x=\"" << left + 36 << "\" y=\"" << ly << "\">"
          << escape(series.name) << "</text>\n";
    }
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace millsim
