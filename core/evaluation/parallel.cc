#include "core/evaluation/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <thread>

namespace sweepscan::evaluation_internal {
namespace {

// Share of the whole evaluation's time per stage (1 M-point lab drive), so
// the overall fraction moves at a roughly even pace.
struct StageShare {
  double start, weight;
};
StageShare Share(EvaluationStage s) {
  switch (s) {
    case EvaluationStage::kNeighbours: return {0.00, 0.62};
    case EvaluationStage::kOutliers: return {0.62, 0.02};
    case EvaluationStage::kDensity: return {0.64, 0.04};
    case EvaluationStage::kPlanes: return {0.68, 0.32};
    case EvaluationStage::kDone: return {1.00, 0.00};
  }
  return {0.0, 0.0};
}

constexpr auto kReportPeriod = std::chrono::milliseconds(20);

}  // namespace

struct Runner::Arena {
  explicit Arena(int n) : arena(n) {}
  tbb::task_arena arena;
};

Runner::Runner(int threads, const EvaluationControl* control) : control_(control) {
  // More threads than cores would only queue (and make oneTBB warn).
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  threads_ = threads > 0 ? std::min(threads, cores) : cores;
  arena_ = std::make_unique<Arena>(threads_);
}

Runner::~Runner() = default;

bool Runner::Cancelled() const {
  if (cancelled_.load(std::memory_order_relaxed)) return true;
  if (control_ != nullptr && control_->cancel != nullptr &&
      control_->cancel->load(std::memory_order_relaxed)) {
    return true;
  }
  return false;
}

bool Runner::For(size_t n, size_t block, const std::function<void(size_t, size_t, size_t)>& body,
                 double from, double to) {
  if (Cancelled()) return false;
  const size_t blocks = Blocks(n, block);
  if (blocks == 0) return true;
  std::atomic<size_t> finished{0};
  const auto run_block = [&](size_t b) {
    if (Cancelled()) return;
    const size_t begin = b * block;
    body(b, begin, std::min(n, begin + block));
    const size_t done = finished.fetch_add(1, std::memory_order_relaxed) + 1;
    Report(from + (to - from) * static_cast<double>(done) / static_cast<double>(blocks));
  };
  if (threads_ == 1 || blocks == 1) {
    for (size_t b = 0; b < blocks && !Cancelled(); ++b) run_block(b);
  } else {
    arena_->arena.execute([&] {
      tbb::parallel_for(
          tbb::blocked_range<size_t>(0, blocks, 1),
          [&](const tbb::blocked_range<size_t>& r) {
            for (size_t b = r.begin(); b != r.end(); ++b) run_block(b);
          },
          tbb::simple_partitioner());
    });
  }
  return !Cancelled();
}

void Runner::Stage(EvaluationStage stage) {
  {
    std::lock_guard<std::mutex> lock(report_mutex_);
    stage_ = stage;
    last_stage_fraction_ = -1.0;
  }
  Report(0.0, /*force=*/true);
}

void Runner::Report(double stage_fraction, bool force) {
  if (control_ == nullptr || !control_->progress) return;
  std::lock_guard<std::mutex> lock(report_mutex_);
  const auto now = std::chrono::steady_clock::now();
  stage_fraction = std::clamp(stage_fraction, 0.0, 1.0);
  if (stage_fraction < last_stage_fraction_) return;
  if (!force && stage_fraction < 1.0 && now - last_report_ < kReportPeriod) return;
  const StageShare share = Share(stage_);
  const double overall = std::max(last_overall_, share.start + share.weight * stage_fraction);
  last_overall_ = overall;
  last_stage_fraction_ = stage_fraction;
  last_report_ = now;
  EvaluationProgress p;
  p.stage = stage_;
  p.stage_fraction = stage_fraction;
  p.fraction = overall;
  if (!control_->progress(p)) cancelled_.store(true, std::memory_order_relaxed);
}

void Runner::Done() {
  {
    std::lock_guard<std::mutex> lock(report_mutex_);
    stage_ = EvaluationStage::kDone;
    last_stage_fraction_ = -1.0;
  }
  Report(1.0, /*force=*/true);
}

}  // namespace sweepscan::evaluation_internal
