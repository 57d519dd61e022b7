// Charts: a log-log line chart with axes, grid, ticks, legend and a dashed reference line.
#include "qjulia/render/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "qjulia/base/error.h"
#include "qjulia/render/text.h"

namespace qjulia {
namespace {

constexpr Rgb kAxis{0, 0, 0}, kGrid{225, 225, 225}, kReference{130, 130, 130};
constexpr int kTextScale = 2;

// A line `width` pixels wide (DDA); with `dashed`, every other run of 6 steps is skipped.
void draw_line(Image& im, double x0, double y0, double x1, double y1, const Rgb& c, int width,
               bool dashed = false) {
  const int steps =
      std::max(1, static_cast<int>(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))));
  for (int s = 0; s <= steps; ++s) {
    if (dashed && (s / 6) % 2) continue;
    const double t = static_cast<double>(s) / steps;
    const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0))) - width / 2;
    const int y = static_cast<int>(std::lround(y0 + t * (y1 - y0))) - width / 2;
    fill_rect(im, x, y, x + width, y + width, c);
  }
}

std::string tick_label(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

bool plotted(double y) { return std::isfinite(y) && y > 0; }

// The chart's pixel frame and its two scales.
struct Axes {
  int w = 0, h = 0, left = 90, right = 30, top = 50, bottom = 70;
  double lx0 = 0, lx1 = 0;  // log2 of the x range
  int d0 = 0, d1 = 1;       // decades of the y range
  double px(double x) const {
    return left + (std::log2(x) - lx0) / std::max(1e-9, lx1 - lx0) * (w - left - right);
  }
  double py(double y) const {
    const double t = (std::log10(std::max(y, std::pow(10.0, d0))) - d0) / (d1 - d0);
    return h - bottom - t * (h - top - bottom);
  }
};

Axes make_axes(const std::vector<double>& xs, const std::vector<PlotSeries>& series,
               const PlotOptions& opts) {
  double ymin = HUGE_VAL, ymax = -HUGE_VAL;
  auto include = [&](double y) {
    if (!plotted(y)) return;
    ymin = std::min(ymin, y);
    ymax = std::max(ymax, y);
  };
  if (opts.reference) include(*opts.reference);
  for (const auto& s : series)
    for (double y : s.values) include(y);
  Axes a;
  a.w = opts.width;
  a.h = opts.height;
  a.lx0 = std::log2(xs.front());
  a.lx1 = std::log2(xs.back());
  // y in whole decades: the distances of an experiment fall over several of them.
  a.d0 = ymin <= ymax ? static_cast<int>(std::floor(std::log10(ymin))) : 0;
  a.d1 = std::max(a.d0 + 1, ymin <= ymax ? static_cast<int>(std::ceil(std::log10(ymax))) : 1);
  return a;
}

void draw_frame(Image& im, const Axes& a, const std::vector<double>& xs, const PlotOptions& opts) {
  for (int d = a.d0; d <= a.d1; ++d) {
    const double y = std::pow(10.0, d);
    draw_line(im, a.left, a.py(y), a.w - a.right, a.py(y), kGrid, 1);
    const std::string label = tick_label(y);
    draw_text(im, a.left - 8 - text_width(label, kTextScale),
              static_cast<int>(a.py(y)) - text_height(kTextScale) / 2, label, kAxis, kTextScale);
  }
  for (double x : xs) {
    draw_line(im, a.px(x), a.h - a.bottom, a.px(x), a.top, kGrid, 1);
    const std::string label = tick_label(x);
    draw_text(im, static_cast<int>(a.px(x)) - text_width(label, kTextScale) / 2,
              a.h - a.bottom + 10, label, kAxis, kTextScale);
  }
  draw_line(im, a.left, a.h - a.bottom, a.w - a.right, a.h - a.bottom, kAxis, 2);
  draw_line(im, a.left, a.h - a.bottom, a.left, a.top, kAxis, 2);
  draw_text(im, (a.w - text_width(opts.x_label, kTextScale)) / 2, a.h - 30, opts.x_label, kAxis,
            kTextScale);
  draw_text(im, (a.w - text_width(opts.title, 3)) / 2, 12, opts.title, kAxis, 3);
  if (opts.reference)
    draw_line(im, a.left, a.py(*opts.reference), a.w - a.right, a.py(*opts.reference), kReference,
              2, true);
}

void draw_legend(Image& im, const Axes& a, const std::vector<PlotSeries>& series,
                 const PlotOptions& opts) {
  int widest = opts.reference ? text_width(opts.reference_label, kTextScale) : 0;
  for (const auto& s : series) widest = std::max(widest, text_width(s.name, kTextScale));
  const int x = a.w - a.right - 50 - widest;
  const int rows = static_cast<int>(series.size()) + (opts.reference ? 1 : 0);
  for (int i = 0; i < rows; ++i) {
    const int y = a.top + 12 + i * 24;
    const bool is_series = i < static_cast<int>(series.size());
    if (is_series)
      fill_rect(im, x, y - 2, x + 28, y + 3, series[i].color);
    else
      draw_line(im, x, y, x + 28, y, kReference, 2, true);
    draw_text(im, x + 40, y - 7, is_series ? series[i].name : opts.reference_label, kAxis,
              kTextScale);
  }
}

void draw_series(Image& im, const Axes& a, const std::vector<double>& xs, const PlotSeries& s) {
  for (std::size_t i = 0; i + 1 < xs.size(); ++i)
    if (plotted(s.values[i]) && plotted(s.values[i + 1]))
      draw_line(im, a.px(xs[i]), a.py(s.values[i]), a.px(xs[i + 1]), a.py(s.values[i + 1]), s.color,
                3);
  for (std::size_t i = 0; i < xs.size(); ++i)
    if (plotted(s.values[i])) {
      const int x = static_cast<int>(a.px(xs[i])), y = static_cast<int>(a.py(s.values[i]));
      fill_rect(im, x - 4, y - 4, x + 5, y + 5, s.color);
    }
}

}  // namespace

Image log_plot(const std::vector<double>& xs, const std::vector<PlotSeries>& series,
               const PlotOptions& opts) {
  if (opts.width < 200 || opts.width > 16384 || opts.height < 200 || opts.height > 16384)
    throw InvalidInput("log_plot: the size must be in 200..16384 per side");
  if (xs.empty()) throw InvalidInput("log_plot: no x values");
  for (std::size_t i = 0; i < xs.size(); ++i)
    if (!(xs[i] > 0 && std::isfinite(xs[i])) || (i > 0 && !(xs[i] > xs[i - 1])))
      throw InvalidInput("log_plot: the x values must be positive, finite and increasing");
  for (const auto& s : series)
    if (s.values.size() != xs.size())
      throw InvalidInput("log_plot: series '" + s.name + "' has " +
                         std::to_string(s.values.size()) + " values for " +
                         std::to_string(xs.size()) + " x values");
  Image im = make_image(opts.width, opts.height, {255, 255, 255});
  const Axes axes = make_axes(xs, series, opts);
  draw_frame(im, axes, xs, opts);
  draw_legend(im, axes, series, opts);
  for (const auto& s : series) draw_series(im, axes, xs, s);
  return im;
}

}  // namespace qjulia
