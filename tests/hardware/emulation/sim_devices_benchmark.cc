// Device simulator speed: simulated seconds per wall-clock second for the
// lab scenario (55 s drive), all three devices streaming, output taken in
// 10 ms steps as the robot agent would. Reported as the counter
// `sim_s_per_wall_s` (docs/simulator.md).
#include <benchmark/benchmark.h>

#include "hardware/emulation/sim_devices.h"
#include "tests/testing/worlds.h"

namespace sweepscan::hardware {
namespace {

void BM_SimDevicesLab(benchmark::State& state) {
  const sim::SimConfig config = testing::LabConfig(1);
  SimDevicesOptions options;
  options.lidar_start_scanning = true;
  double simulated_s = 0;
  size_t bytes = 0;
  for (auto _ : state) {
    SimDevices devices(config, SimDevices::Mode::kScripted, options);
    std::vector<TimedBytes> out;
    const Time start = TimeFromSeconds(sim::SimWorld::kStartTimeS);
    const Time end = devices.world().end_time() + FromSeconds(0.1);
    for (Time t = start; t < end; t += FromSeconds(0.01)) {
      devices.AdvanceTo(t, &out);
      for (const TimedBytes& b : out) bytes += b.bytes.size();
      out.clear();
    }
    devices.AdvanceTo(end, &out);
    simulated_s += config.DurationSeconds();
  }
  state.counters["sim_s_per_wall_s"] = benchmark::Counter(simulated_s, benchmark::Counter::kIsRate);
  state.counters["bytes_per_s"] =
      benchmark::Counter(static_cast<double>(bytes), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimDevicesLab)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
}  // namespace sweepscan::hardware

BENCHMARK_MAIN();
