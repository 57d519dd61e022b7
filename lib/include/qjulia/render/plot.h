#pragma once
/// @file plot.h
/// Charts for experiment reports: a line chart on logarithmic axes, drawn with the one font.
#include <optional>
#include <string>
#include <vector>

#include "qjulia/render/image.h"

namespace qjulia {

/// One line of a chart.
struct PlotSeries {
  std::string name;            ///< its legend entry
  Rgb color{0, 0, 0};          ///< line and marker colour
  std::vector<double> values;  ///< one per x; a non-finite or non-positive value is no point
};

/// Options of log_plot().
struct PlotOptions {
  int width = 900, height = 560;  ///< pixels, each 200..16384
  std::string title;              ///< centred above the chart
  std::string x_label;            ///< centred below the x axis
  /// A dashed grey horizontal line (e.g. the resolution limit), with its legend entry.
  std::optional<double> reference;
  std::string reference_label;
};

/// A line chart of `series` over `xs` with a log2 x axis (one tick per x) and a log10 y axis
/// in whole decades covering every finite positive value and the reference; markers at the
/// points, lines between neighbouring points, a legend at the top right; white background.
/// @throws InvalidInput when `xs` is empty or not increasing and positive, a series has not one
///         value per x, or the size is out of range.
Image log_plot(const std::vector<double>& xs, const std::vector<PlotSeries>& series,
               const PlotOptions& opts = {});

}  // namespace qjulia
