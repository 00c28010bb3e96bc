// Deterministic parallel loops for the evaluation (oneTBB underneath).
//
// Work over [0, n) is cut into blocks of a fixed size that does not depend on
// the thread count; a loop body writes per-block results that the caller
// combines in block order, so sums come out bit for bit the same on 1 and on
// N threads. Every block first checks for a cancel; a block is small (a few
// milliseconds of work), so a cancel stops the loop within a few blocks.
//
// Progress is reported per stage: the stage's fraction rises as blocks
// finish, and the overall fraction (stages weighted by their usual share of
// the time) never goes down. The callback runs one call at a time, from
// whichever worker finished a block, at most about 50 times a second.
#ifndef SWEEPSCAN_CORE_EVALUATION_PARALLEL_H_
#define SWEEPSCAN_CORE_EVALUATION_PARALLEL_H_

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>

#include "core/evaluation/evaluation.h"

namespace sweepscan::evaluation_internal {

class Runner {
 public:
  // threads <= 0: all hardware threads; at most that many. control may be null.
  Runner(int threads, const EvaluationControl* control);
  ~Runner();
  Runner(const Runner&) = delete;
  Runner& operator=(const Runner&) = delete;

  int threads() const { return threads_; }

  // Number of blocks of `block` items over n items.
  static size_t Blocks(size_t n, size_t block) { return (n + block - 1) / block; }

  // Runs body(b, begin, end) for every block b of [0, n); the stage's
  // fraction goes from `from` to `to` of the stage as blocks finish.
  // Returns false if cancelled (some blocks may then not have run).
  bool For(size_t n, size_t block, const std::function<void(size_t, size_t, size_t)>& body,
           double from = 0.0, double to = 1.0);

  // Enters a stage (reports its fraction 0) / reports a fraction of it.
  void Stage(EvaluationStage stage);
  void Report(double stage_fraction, bool force = false);
  // Reports the end (stage kDone, fraction 1).
  void Done();

  // True once cancelled (the flag, or the callback returned false).
  bool Cancelled() const;

 private:
  struct Arena;
  int threads_;
  const EvaluationControl* control_;
  std::unique_ptr<Arena> arena_;
  std::atomic<bool> cancelled_{false};
  std::mutex report_mutex_;
  EvaluationStage stage_ = EvaluationStage::kNeighbours;
  double last_overall_ = 0.0;
  double last_stage_fraction_ = 0.0;
  std::chrono::steady_clock::time_point last_report_{};
};

}  // namespace sweepscan::evaluation_internal

#endif  // SWEEPSCAN_CORE_EVALUATION_PARALLEL_H_
