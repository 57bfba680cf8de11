#include "support/svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace capsflow {
namespace {

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

// "Nice" tick step for a range (1, 2 or 5 times a power of ten).
double tick_step(double range) {
  const double raw = range / 5.0;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10.0 * p;
}

std::string escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else o += c;
  }
  return o;
}

}  // namespace

std::string svg_line_plot(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                          const std::vector<PlotSeries>& series) {
  double x0 = std::numeric_limits<double>::max(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : series)
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  // A range that is empty or below the doubles' resolution at its values (a pinned capsule's constant height
  // differs from itself only in the last bits) is widened: a tick step below one ulp would never advance.
  auto widen = [](double& lo, double& hi) {
    if (!std::isfinite(lo) || !std::isfinite(hi)) {
      lo = 0.0;
      hi = 1.0;
      return;
    }
    const double scale = std::max({1.0, std::abs(lo), std::abs(hi)});
    if (hi - lo < 1e-9 * scale) {
      const double mid = 0.5 * (lo + hi), half = 0.5 * std::max(1e-3 * scale, 1e-9);
      lo = mid - half;
      hi = mid + half;
    }
  };
  widen(x0, x1);
  widen(y0, y1);
  const double pad = 0.05 * (y1 - y0);
  y0 -= pad;
  y1 += pad;
  const double W = 720, Hh = 460, L = 80, R = 200, T = 40, B = 60;
  auto px = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
  auto py = [&](double y) { return Hh - B - (y - y0) / (y1 - y0) * (Hh - T - B); };
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << Hh
    << "\" font-family=\"sans-serif\" font-size=\"13\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<text x=\"" << W / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" << escape(title) << "</text>\n";
  o << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << W - L - R << "\" height=\"" << Hh - T - B
    << "\" fill=\"none\" stroke=\"black\"/>\n";
  const double sx = tick_step(x1 - x0), sy = tick_step(y1 - y0);
  // Ticks by index, not by accumulation: bounded whatever the range (at most ~10 with tick_step's choice).
  const long ix0 = static_cast<long>(std::ceil(x0 / sx)), iy0 = static_cast<long>(std::ceil(y0 / sy));
  for (long k = ix0; k <= ix0 + 100; ++k) {
    const double t = static_cast<double>(k) * sx;
    if (t > x1 + 1e-12 * sx) break;
    o << "<line x1=\"" << px(t) << "\" y1=\"" << Hh - B << "\" x2=\"" << px(t) << "\" y2=\"" << Hh - B + 5
      << "\" stroke=\"black\"/><text x=\"" << px(t) << "\" y=\"" << Hh - B + 20 << "\" text-anchor=\"middle\">"
      << fmt(std::abs(t) < 1e-12 * sx ? 0.0 : t) << "</text>\n";
  }
  for (long k = iy0; k <= iy0 + 100; ++k) {
    const double t = static_cast<double>(k) * sy;
    if (t > y1 + 1e-12 * sy) break;
    o << "<line x1=\"" << L - 5 << "\" y1=\"" << py(t) << "\" x2=\"" << L << "\" y2=\"" << py(t)
      << "\" stroke=\"black\"/><text x=\"" << L - 8 << "\" y=\"" << py(t) + 4 << "\" text-anchor=\"end\">"
      << fmt(std::abs(t) < 1e-12 * sy ? 0.0 : t) << "</text>\n";
  }
  o << "<text x=\"" << (L + W - R) / 2 << "\" y=\"" << Hh - 15 << "\" text-anchor=\"middle\">" << escape(xlabel)
    << "</text>\n";
  o << "<text transform=\"translate(20," << (T + Hh - B) / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
    << escape(ylabel) << "</text>\n";
  int k = 0;
  for (const auto& s : series) {
    o << "<polyline fill=\"none\" stroke=\"" << s.color << "\" stroke-width=\"2\""
      << (s.dashed ? " stroke-dasharray=\"6,4\"" : "") << " points=\"";
    for (std::size_t i = 0; i < s.x.size(); ++i) o << px(s.x[i]) << "," << py(s.y[i]) << " ";
    o << "\"/>\n";
    if (s.label.empty()) continue;  // unlabelled series (e.g. one line per capsule) stay out of the legend
    const double ly = T + 20 + 22 * k++;
    o << "<line x1=\"" << W - R + 15 << "\" y1=\"" << ly << "\" x2=\"" << W - R + 45 << "\" y2=\"" << ly
      << "\" stroke=\"" << s.color << "\" stroke-width=\"2\"" << (s.dashed ? " stroke-dasharray=\"6,4\"" : "")
      << "/><text x=\"" << W - R + 50 << "\" y=\"" << ly + 4 << "\">" << escape(s.label) << "</text>\n";
  }
  o << "</svg>\n";
  return o.str();
}

}  // namespace capsflow
