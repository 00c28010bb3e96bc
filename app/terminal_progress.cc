#include "app/terminal_progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <utility>

namespace sweepscan::app {

TerminalProgress::TerminalProgress(bool on, std::string title)
    : on_(on), title_(std::move(title)) {}

bool TerminalProgress::Wanted(bool json) { return !json && ::isatty(STDERR_FILENO) != 0; }

void TerminalProgress::Show(const std::string& stage, double fraction) {
  if (!on_) return;
  const int percent = static_cast<int>(100.0 * std::clamp(fraction, 0.0, 1.0));
  if (percent == last_percent_ && stage == last_stage_) return;
  // \r and "erase to the end of the line" (ECMA-48 EL): the line is
  // rewritten where it stands, however long the last one was.
  std::fprintf(stderr, "\r\033[K%s: %s %3d %%", title_.c_str(), stage.c_str(), percent);
  std::fflush(stderr);
  last_percent_ = percent;
  last_stage_ = stage;
  shown_ = true;
}

std::function<bool(double)> TerminalProgress::Stage(const std::string& what) {
  if (!on_) return nullptr;
  return [this, what](double fraction) {
    Show(what, fraction);
    return true;
  };
}

void TerminalProgress::Clear() {
  if (!shown_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  shown_ = false;
  last_percent_ = -1;
  last_stage_.clear();
}

}  // namespace sweepscan::app
