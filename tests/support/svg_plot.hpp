#pragma once
// Minimal line plots as standalone SVG, for the validation programs' figures (docs/figures/*.svg) only: they are
// drawn by the test binaries themselves, without a Python stack. The product draws with matplotlib alone
// (`capsflow figures`, tools/capsflow_figures.py).
#include <string>
#include <vector>

namespace capsflow {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  std::string color = "#1f77b4";
  bool dashed = false;
};

// Returns the SVG text of one plot with axes, ticks, labels and a legend (series with an empty label are drawn but
// not listed).
std::string svg_line_plot(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                          const std::vector<PlotSeries>& series);

}  // namespace capsflow
