// Progress of a long command on a terminal, one line on stderr rewritten in
// place ("simulate lab_43200: placing the points  42 %"), as evaluate has
// shown it. Off unless stderr is a terminal and the command prints no JSON,
// so scripts and logs see only the results; the line is cleared when the
// progress ends, so what follows starts on a clean line.
#ifndef SWEEPSCAN_APP_TERMINAL_PROGRESS_H_
#define SWEEPSCAN_APP_TERMINAL_PROGRESS_H_

#include <functional>
#include <string>

namespace sweepscan::app {

class TerminalProgress {
 public:
  // `title`: what is being done to what ("simulate lab_43200").
  TerminalProgress(bool on, std::string title);
  ~TerminalProgress() { Clear(); }
  TerminalProgress(const TerminalProgress&) = delete;
  TerminalProgress& operator=(const TerminalProgress&) = delete;

  // stderr is a terminal and `json` (the command prints JSON) is false.
  static bool Wanted(bool json);

  // The stage and the fraction of it done (0..1); written only when the
  // whole percent or the stage changes (a call per record costs nothing).
  void Show(const std::string& stage, double fraction);
  void Clear();
  bool on() const { return on_; }
  // Show(what, fraction) as a progress callback that never cancels (the
  // decoders' DecodeProgress); empty when off, so the callee skips it.
  std::function<bool(double)> Stage(const std::string& what);

 private:
  bool on_;
  std::string title_;
  std::string last_stage_;
  int last_percent_ = -1;
  bool shown_ = false;
};

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_TERMINAL_PROGRESS_H_
