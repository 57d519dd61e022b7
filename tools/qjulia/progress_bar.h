#pragma once
// A progress bar with stage names on stderr, drawn only when stderr is a terminal.
#include <chrono>
#include <string>

#include "qjulia/pipeline/pipeline.h"

namespace qjulia::cli {

class ProgressBar {
 public:
  /// Draws only if stderr is a terminal and `quiet` is false.
  explicit ProgressBar(bool quiet = false);
  ~ProgressBar();
  /// A callback for PipelineOptions::progress (never cancels).
  StageProgressFn callback();
  /// Updates the bar.
  void update(const std::string& stage, double fraction);
  /// Clears the bar line.
  void finish();

 private:
  bool enabled_;
  std::string stage_;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace qjulia::cli
