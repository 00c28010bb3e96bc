// Writes the seed corpora in tests/fuzz/corpus/<codec>/ from the encoders, so
// the fuzzers start from well-formed streams. Each file is
// <chunk-selector byte> + stream, as the fuzz targets expect.
// Usage: make_seed_corpus <corpus dir> <vendor test vector dir, tests/data/vendor>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "hardware/codecs/hi219_codec.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/codecs/x4_codec.h"
#include "tests/fuzz/seed_files.h"

namespace {

using sweepscan::fuzz::Bytes;
using namespace sweepscan::hardware;

using sweepscan::fuzz::Append;
using sweepscan::fuzz::ReadFile;
using sweepscan::fuzz::WriteSeed;

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <corpus dir> <vendor test vector dir, tests/data/vendor>\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  const std::string testdata = argv[2];
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> dist_mm(0, 9000);

  // X4: responses, a short revolution, and the vendor vector.
  {
    Bytes responses = EncodeX4DeviceInfo(X4DeviceInfo{kX4ModelCode, 0x0106, 1, {}, {}});
    Append(EncodeX4Health(X4Health{0, 0, {}}), &responses);
    Append(EncodeX4ScanStartHeader(), &responses);
    WriteSeed(dir + "/x4/responses", 0, responses);
    Bytes scan = EncodeX4ScanStartHeader();
    for (int r = 0; r < 2; ++r) {
      X4PacketToEncode ring;
      ring.ring_start = true;
      ring.scan_frequency_hz = 7.0;
      ring.distances_mm = {0};
      EncodeX4ScanPacket(ring, &scan);
      for (int k = 0; k < 2; ++k) {
        X4PacketToEncode p;
        for (int i = 0; i < 40; ++i) p.distances_mm.push_back(i % 5 ? dist_mm(rng) : 0);
        p.first_angle_deg = 180.0 * k;
        p.last_angle_deg = 180.0 * k + 170;
        EncodeX4ScanPacket(p, &scan);
      }
    }
    WriteSeed(dir + "/x4/revolutions", 7, scan);
    WriteSeed(dir + "/x4/doc_zero_packet", 0, ReadFile(testdata + "/ydlidar_doc_zero_packet.bin"));
  }
  // HI219: the vendor 0x91 frame, a legacy frame, both back to back.
  {
    const Bytes vendor = ReadFile(testdata + "/hipnuc_hi91_example_frame.bin");
    WriteSeed(dir + "/hi219/vendor_91", 0, vendor);
    ImuSample s;
    s.fields = kImuUserId | kImuAcc | kImuGyro | kImuMag | kImuEuler | kImuQuat | kImuPressure;
    s.acc_g = {0.01f, -0.02f, 0.99f};
    s.gyro_dps = {1.5f, -2.5f, 10.0f};
    s.mag_ut = {20.0f, -5.0f, 40.0f};
    s.pitch_deg = 1.25f;
    s.roll_deg = -3.5f;
    s.yaw_deg = 90.0f;
    s.quat_wxyz = {1.0f, 0.0f, 0.0f, 0.0f};
    s.pressure_pa = 101325.0f;
    const Bytes legacy = EncodeHi219LegacyFrame(s);
    WriteSeed(dir + "/hi219/legacy", 0, legacy);
    Bytes both = vendor;
    Append(legacy, &both);
    WriteSeed(dir + "/hi219/mixed", 13, both);
  }
  // Motor board: commands and feedback.
  {
    Bytes cmds;
    Bytes fbs;
    for (int i = 0; i < 3; ++i) {
      MotorCommand c;
      c.vx_mps = 0.3 * i;
      c.wz_radps = -0.5 * i;
      Append(EncodeMotorCommand(c), &cmds);
      MotorFeedback f;
      f.vx_mps = 0.3 * i;
      f.acc_mps2 = {0.1, 0.0, 9.81};
      f.gyro_radps = {0.0, 0.0, 0.2 * i};
      f.voltage_v = 12.1;
      Append(EncodeMotorFeedback(f), &fbs);
    }
    WriteSeed(dir + "/motor_board/commands", 0, cmds);
    WriteSeed(dir + "/motor_board/feedback", 5, fbs);
  }
  return 0;
}
