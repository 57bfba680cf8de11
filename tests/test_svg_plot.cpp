// svg_line_plot on degenerate data: a constant series (a pinned capsule's height), a range below the doubles'
// resolution at its values, and non-finite values give a bounded plot at once (the end-of-run plot of a pinned
// run used to loop forever on a tick step below one ulp, growing to 16 GB).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "support/svg_plot.hpp"

namespace {

using capsflow::PlotSeries;
using capsflow::svg_line_plot;

std::size_t ticks(const std::string& svg) {
  std::size_t n = 0;
  for (std::size_t p = svg.find("<line"); p != std::string::npos; p = svg.find("<line", p + 1)) ++n;
  return n;
}

TEST(SvgPlot, DegenerateRangesGiveABoundedPlot) {
  const double half = 0.5;
  const std::vector<std::vector<double>> ys = {
      {half, half, half},                                              // constant
      {half, std::nextafter(half, 1.0), half},                         // one ulp apart
      {1e8, 1e8 + 1e-8, 1e8},                                          // below the resolution at 1e8
      {0.0, 0.0, 0.0},
      {std::numeric_limits<double>::quiet_NaN(), 1.0, 2.0},
  };
  for (const auto& y : ys) {
    PlotSeries s;
    s.x = {0.0, 1.0, 2.0};
    s.y = y;
    const std::string svg = svg_line_plot("t", "x", "y", {s});
    EXPECT_LT(svg.size(), 20000u);
    EXPECT_GE(ticks(svg), 4u);   // both axes carry ticks
    EXPECT_LE(ticks(svg), 60u);
  }
  PlotSeries flat_x;  // all points at one x
  flat_x.x = {3.0, 3.0};
  flat_x.y = {1.0, 2.0};
  EXPECT_LT(svg_line_plot("t", "x", "y", {flat_x}).size(), 20000u);
}

}  // namespace
