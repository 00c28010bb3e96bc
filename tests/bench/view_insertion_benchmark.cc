// GUI-thread time of live insertion (issue 28: "an hour of insertion must
// cost under a second of GUI time"): the view takes hours of an X4's points
// (5 000 a second) as the app's tick does (ui/main_window.cc OnTick: the
// sealed chunks of a LiveBatch, then the open chunk's new points, moved), with the
// same chunks and batches as the live processor (ui/workspace/
// live_processor.cc Publish). Only CloudView::AppendSealed and AppendPoints
// are timed, as the app's insertion_ms times them; making the batches
// (assembly, packing: the processing thread's work) is not.
//
// The points are the simulated lab drive (tests/testing/worlds.h) driven
// again and again, each round 0.2 m further along and later in time: a
// room's walls seen many times, as a day of scanning sees them.
//
// Run (a display is not needed: QT_QPA_PLATFORM defaults to offscreen here):
//   ninja -C build view_insertion_benchmark && build/tests/view_insertion_benchmark
// Arguments: the replay speed (1: live, one tick's 33 ms of points a batch;
// 20: a 20x replay's 0.67 s a batch) and the hours of scanning. Counter
// gui_s_per_hour: GUI seconds an hour of scanning. Figures in
// docs/performance.md ("Live insertion, measured alone").
#include <benchmark/benchmark.h>

#include <QApplication>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/cloud/cloud_pager.h"
#include "core/cloud/packed_chunk.h"
#include "tests/testing/worlds.h"
#include "ui/view/cloud_view.h"

namespace sweepscan {
namespace {

constexpr double kPointsPerSecond = 5000.0;  // An X4 at its default rate.
constexpr double kTickS = 0.033;             // The app's tick (main_window.cc kTickMs).

const std::vector<CloudPoint>& LabPoints() {
  static const auto* points = new std::vector<CloudPoint>(
      testing::SimulateAndReconstruct(testing::LabConfig(), PoseSource::kEkf, true).points);
  return *points;
}

// The points of an endless drive: the lab drive, round after round.
class Drive {
 public:
  explicit Drive(const std::vector<CloudPoint>& lab) : lab_(lab) {
    span_ns_ = lab_.back().time_ns - lab_.front().time_ns + 100'000'000;
  }
  CloudPoint Next() {
    if (i_ == lab_.size()) {
      i_ = 0;
      ++round_;
    }
    CloudPoint p = lab_[i_++];
    p.x += 0.2f * static_cast<float>(round_ % 10);
    p.time_ns += round_ * span_ns_;
    p.scan += static_cast<uint32_t>(round_ * 100'000);
    return p;
  }

 private:
  const std::vector<CloudPoint>& lab_;
  int64_t span_ns_ = 0;
  size_t i_ = 0;
  int64_t round_ = 0;
};

void BM_LiveInsertion(benchmark::State& state) {
  const double speed = static_cast<double>(state.range(0));
  const double hours = static_cast<double>(state.range(1));
  const size_t per_batch = static_cast<size_t>(kPointsPerSecond * kTickS * speed);
  const size_t total = static_cast<size_t>(kPointsPerSecond * 3600.0 * hours);
  for (auto _ : state) {
    ui::CloudView view;
    CloudPager pager;
    PointChunks chunks(ui::CloudView::kChunkPoints, &pager);
    Drive drive(LabPoints());
    size_t published_chunk = 0, published_offset = 0;
    double seconds = 0.0;
    for (size_t n = 0; n < total;) {
      // The processing thread's share: assembly into the store, sealing.
      for (size_t k = 0; k < per_batch && n < total; ++k, ++n) chunks.Append(drive.Next());
      std::vector<std::shared_ptr<const PackedChunk>> sealed;
      std::vector<std::shared_ptr<const ChunkPayload>> unpacked;
      const auto all = chunks.SealedChunks();
      for (; published_chunk < all.size(); ++published_chunk) {
        sealed.push_back(all[published_chunk]);
        unpacked.push_back(all[published_chunk]->unpacked() ? nullptr
                                                            : all[published_chunk]->Pin());
        published_offset = 0;
      }
      const CloudChunk& open = chunks.open_chunk();
      std::vector<CloudPoint> points(open.begin() + published_offset, open.end());
      published_offset = open.size();
      // The GUI thread's: what OnTick's insertion_ms times.
      const auto start = std::chrono::steady_clock::now();
      view.AppendSealed(sealed, unpacked);
      view.AppendPoints(std::move(points));  // As the app's tick: kept, not copied.
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    benchmark::DoNotOptimize(view.point_count());
    state.SetIterationTime(seconds);
    state.counters["gui_s_per_hour"] = seconds / hours;
    state.counters["points"] = static_cast<double>(view.point_count());
  }
}
BENCHMARK(BM_LiveInsertion)
    ->ArgNames({"speed", "hours"})
    ->Args({1, 1})
    ->Args({20, 1})
    ->Args({20, 3})
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace sweepscan

int main(int argc, char** argv) {
  // The view is never shown: no display is needed, and none is opened.
  setenv("QT_QPA_PLATFORM", "offscreen", 0);
  QApplication app(argc, argv);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
