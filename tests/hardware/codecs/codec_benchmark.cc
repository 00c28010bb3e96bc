// Decode throughput of the vendor codecs on realistic streams, fed in
// serial-read-sized chunks (the argument: bytes per Feed()). Reported as
// bytes/s via SetBytesProcessed. For scale: the X4 sends ~18 kB/s at
// 128000 baud, the HI219 ~8 kB/s at 100 Hz, the motor board ~2.4 kB/s.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "hardware/codecs/hi219_codec.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/codecs/x4_codec.h"

namespace sweepscan {
namespace hardware {
namespace {

using Bytes = std::vector<uint8_t>;

constexpr size_t kStreamBytes = 1 << 20;

// ~7 Hz revolutions of 40-sample packets with 20 % invalid samples.
Bytes MakeX4Stream() {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> dist_mm(120, 10000);
  std::bernoulli_distribution invalid(0.2);
  Bytes out = EncodeX4ScanStartHeader();
  const int packets_per_rev = 18;
  const double step = 360.0 / (packets_per_rev * 40);
  while (out.size() < kStreamBytes) {
    X4PacketToEncode ring;
    ring.ring_start = true;
    ring.scan_frequency_hz = 7.0;
    ring.distances_mm = {0};
    EncodeX4ScanPacket(ring, &out);
    for (int k = 0; k < packets_per_rev; ++k) {
      X4PacketToEncode p;
      for (int i = 0; i < 40; ++i) p.distances_mm.push_back(invalid(rng) ? 0 : dist_mm(rng));
      p.first_angle_deg = k * 40 * step;
      p.last_angle_deg = (k * 40 + 39) * step;
      EncodeX4ScanPacket(p, &out);
    }
  }
  return out;
}

Bytes MakeHi219Stream() {
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-1, 1);
  Bytes out;
  uint32_t t_ms = 0;
  while (out.size() < kStreamBytes) {
    ImuSample s;
    s.fields = kImuMainStatus | kImuTemperature | kImuPressure | kImuSystemTime | kImuAcc |
               kImuGyro | kImuMag | kImuEuler | kImuQuat;
    s.system_time_ms = t_ms += 10;
    s.acc_g = {0.05f * u(rng), 0.05f * u(rng), 1.0f + 0.05f * u(rng)};
    s.gyro_dps = {u(rng), u(rng), 20 * u(rng)};
    s.yaw_deg = 180 * u(rng);
    s.quat_wxyz = {1, 0, 0, 0};
    const Bytes f = EncodeHi219Packet91Frame(s);
    out.insert(out.end(), f.begin(), f.end());
  }
  return out;
}

Bytes MakeMotorFeedbackStream() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  Bytes out;
  while (out.size() < kStreamBytes) {
    MotorFeedback f;
    f.vx_mps = 0.5 + 0.1 * u(rng);
    f.wz_radps = 0.3 * u(rng);
    f.acc_mps2 = {0.2 * u(rng), 0.2 * u(rng), 9.81 + 0.1 * u(rng)};
    f.gyro_radps = {0.01 * u(rng), 0.01 * u(rng), 0.3 * u(rng)};
    f.voltage_v = 12.0;
    const Bytes b = EncodeMotorFeedback(f);
    out.insert(out.end(), b.begin(), b.end());
  }
  return out;
}

template <typename Decoder, typename Drain>
void Decode(benchmark::State& state, const Bytes& stream, Drain drain) {
  const size_t chunk = static_cast<size_t>(state.range(0));
  for (auto _ : state) {
    Decoder d;
    for (size_t pos = 0; pos < stream.size(); pos += chunk) {
      d.Feed(stream.data() + pos, std::min(chunk, stream.size() - pos), Time());
      drain(&d);
    }
    benchmark::DoNotOptimize(d.stats().frames_ok);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(stream.size()));
}

void BM_X4Decode(benchmark::State& state) {
  static const Bytes stream = MakeX4Stream();
  size_t samples = 0;
  Decode<X4Decoder>(state, stream, [&samples](X4Decoder* d) {
    for (const auto& p : d->TakePackets()) samples += p.samples.size();
    for (const auto& s : d->TakeScans()) samples += s.samples.size();
  });
  benchmark::DoNotOptimize(samples);
}
BENCHMARK(BM_X4Decode)->Arg(64)->Arg(4096);

void BM_X4DecodeScansOnly(benchmark::State& state) {
  static const Bytes stream = MakeX4Stream();
  size_t samples = 0;
  const size_t chunk = static_cast<size_t>(state.range(0));
  X4DecoderOptions options;
  options.keep_packets = false;
  for (auto _ : state) {
    X4Decoder d(options);
    for (size_t pos = 0; pos < stream.size(); pos += chunk) {
      d.Feed(stream.data() + pos, std::min(chunk, stream.size() - pos), Time());
      for (const auto& s : d.TakeScans()) samples += s.samples.size();
    }
  }
  benchmark::DoNotOptimize(samples);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(stream.size()));
}
BENCHMARK(BM_X4DecodeScansOnly)->Arg(4096);

void BM_Hi219Decode(benchmark::State& state) {
  static const Bytes stream = MakeHi219Stream();
  Decode<Hi219Decoder>(state, stream,
                       [](Hi219Decoder* d) { benchmark::DoNotOptimize(d->TakeSamples().size()); });
}
BENCHMARK(BM_Hi219Decode)->Arg(64)->Arg(4096);

void BM_MotorFeedbackDecode(benchmark::State& state) {
  static const Bytes stream = MakeMotorFeedbackStream();
  Decode<MotorFeedbackDecoder>(state, stream, [](MotorFeedbackDecoder* d) {
    benchmark::DoNotOptimize(d->TakeRecords().size());
  });
}
BENCHMARK(BM_MotorFeedbackDecode)->Arg(64)->Arg(4096);

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

BENCHMARK_MAIN();
