// Link decode throughput (LinkDecoder, frames + CRC-32C + payload parsing)
// on a realistic agent -> workstation stream: Telemetry of the three devices
// in the sizes the agent reads them (X4 ~ 90-byte packets, HI219 82-byte
// frames, motor board 24-byte frames) plus Status and acks. Fed in
// read-sized chunks (the argument: bytes per Feed()); plus the raw CRC-32C.
// Reported as bytes/s via SetBytesProcessed.
// For scale: a live link carries ~30 kB/s.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "core/common/crc32c.h"
#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {
namespace {

using Bytes = std::vector<uint8_t>;

constexpr size_t kStreamBytes = 4 << 20;

Bytes MakeAgentStream() {
  std::mt19937 rng(1);
  LinkEncoder enc(LinkSender::kAgent);
  Bytes out;
  Time t = TimeFromSeconds(1.0);
  Bytes lidar(90), imu(82), motor(24);
  while (out.size() < kStreamBytes) {
    for (auto* b : {&lidar, &imu, &motor}) {
      for (auto& x : *b) x = static_cast<uint8_t>(rng());
    }
    t += std::chrono::milliseconds(5);
    Bytes f = enc.EncodeTelemetry(t, LinkDevice::kLidar, t, lidar.data(), lidar.size());
    out.insert(out.end(), f.begin(), f.end());
    f = enc.EncodeTelemetry(t, LinkDevice::kImu, t, imu.data(), imu.size());
    out.insert(out.end(), f.begin(), f.end());
    f = enc.EncodeTelemetry(t, LinkDevice::kMotorBoard, t, motor.data(), motor.size());
    out.insert(out.end(), f.begin(), f.end());
    if (rng() % 20 == 0) {
      f = enc.Encode(t, LinkStatus{});
      out.insert(out.end(), f.begin(), f.end());
    }
  }
  return out;
}

void BM_LinkDecode(benchmark::State& state) {
  static const Bytes stream = MakeAgentStream();
  const size_t chunk = static_cast<size_t>(state.range(0));
  size_t messages = 0;
  for (auto _ : state) {
    LinkDecoder d;
    std::vector<LinkMessage> out;
    for (size_t pos = 0; pos < stream.size(); pos += chunk) {
      d.Feed(stream.data() + pos, std::min(chunk, stream.size() - pos), &out);
      messages += out.size();
      out.clear();
    }
  }
  benchmark::DoNotOptimize(messages);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(stream.size()));
}
BENCHMARK(BM_LinkDecode)->Arg(64)->Arg(4096)->Arg(65536);

// The same stream with 1 % of the bytes corrupted: resync cost.
void BM_LinkDecodeCorrupted(benchmark::State& state) {
  static const Bytes stream = [] {
    Bytes s = MakeAgentStream();
    std::mt19937 rng(2);
    for (size_t i = 0; i < s.size() / 100; ++i) s[rng() % s.size()] ^= 0x5A;
    return s;
  }();
  for (auto _ : state) {
    LinkDecoder d;
    std::vector<LinkMessage> out;
    for (size_t pos = 0; pos < stream.size(); pos += 4096) {
      d.Feed(stream.data() + pos, std::min<size_t>(4096, stream.size() - pos), &out);
      out.clear();
    }
    benchmark::DoNotOptimize(d.stats().codec.frames_ok);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(stream.size()));
}
BENCHMARK(BM_LinkDecodeCorrupted);

void BM_Crc32c(benchmark::State& state) {
  static const Bytes data = MakeAgentStream();
  for (auto _ : state) benchmark::DoNotOptimize(Crc32c(data.data(), data.size()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(data.size()));
}
BENCHMARK(BM_Crc32c);

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

BENCHMARK_MAIN();
