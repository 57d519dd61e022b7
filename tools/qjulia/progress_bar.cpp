#include "progress_bar.h"

#include <unistd.h>

#include <cstdio>

namespace qjulia::cli {

ProgressBar::ProgressBar(bool quiet) : enabled_(!quiet && isatty(STDERR_FILENO)) {}

ProgressBar::~ProgressBar() { finish(); }

StageProgressFn ProgressBar::callback() {
  return [this](const std::string& stage, double fraction) {
    update(stage, fraction);
    return true;
  };
}

void ProgressBar::update(const std::string& stage, double fraction) {
  if (!enabled_) return;
  const int percent = static_cast<int>(fraction * 100.0 + 0.5);
  const auto now = std::chrono::steady_clock::now();
  // Redraw on a new stage, or at most every 50 ms.
  if (stage == stage_ &&
      (percent == last_percent_ || now - last_draw_ < std::chrono::milliseconds(50)))
    return;
  stage_ = stage;
  last_percent_ = percent;
  last_draw_ = now;
  constexpr int kWidth = 30;
  const int filled = percent * kWidth / 100;
  std::fprintf(stderr, "\r%-10s [%.*s%*s] %3d%%", stage.c_str(), filled,
               "##############################", kWidth - filled, "", percent);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!enabled_ || stage_.empty()) return;
  std::fprintf(stderr, "\r%*s\r", 60, "");
  std::fflush(stderr);
  stage_.clear();
}

}  // namespace qjulia::cli
