// A session's cloud in memory that does not grow with the session: two
// passes over frames.bin, each visiting it record by record
// (DecodeSessionStreaming).
//
//   pass 1  decode the wheel and IMU records and keep them (the lidar's
//           bytes are skipped undecoded); estimate the poses (EKF,
//           odometry, or given).
//   pass 2  decode the lidar's bytes; place each scan as it comes
//           (Assembler, the same per-sample deskew as Reconstruct) and hand
//           its points to a sink.
//
// The points, their order and every count are Reconstruct's, bit for bit.
// What stays in memory is the motion records (pass 1 only: about 6 kB a
// second of drive at the HI219's 100 Hz and the motor board's 50 Hz) and
// the poses (one a filter step, 7 kB a second), plus one scan and one chunk
// of points: 0.63 GB peak for a 10-hour drive of 175 M points, where
// holding it decoded takes 24 B a lidar sample plus 32 B a point, 14 GB
// (docs/performance.md, "The CLI on long sessions"). The decode runs
// twice; even so a session streams 3 times faster than it decoded whole.
//
// Pure, no Qt. Pass 2 places the points on a second thread of its own
// while the calling thread decodes; the sink is called on that thread, one
// call at a time, and PlacePoints returns after its last call.
#ifndef SWEEPSCAN_HARDWARE_STATION_SESSION_STREAM_H_
#define SWEEPSCAN_HARDWARE_STATION_SESSION_STREAM_H_

#include <functional>
#include <string>

#include "core/cloud/reconstruct.h"
#include "core/common/status.h"
#include "hardware/link/telemetry_decoder.h"

namespace sweepscan::hardware {

class SessionCloudStream {
 public:
  // Points in time order, at most 65 536 a call; an error stops pass 2
  // and is returned by PlacePoints.
  using PointSink = std::function<Status(const CloudPoint* points, size_t n)>;

  // Pass 1. `options` as for Reconstruct (calibration, initial pose, pose
  // source); `given` the poses for kTruth / kSfm. Damage in frames.bin is
  // skipped or refused as `frames_options` say (decode().frames).
  Status EstimatePoses(const std::string& session_dir, const FramesLoadOptions& frames_options,
                       const ReconstructionOptions& options, const PoseBuffer* given = nullptr,
                       const DecodeProgress& progress = nullptr);

  // After pass 1: what the decode found (the frames' damage, meta, link;
  // the lidar's codec counts, telemetry.x4, come with pass 2),
  // and the poses, EKF counters and gaps (result().points stays empty;
  // stats and gap counts come with pass 2).
  const SessionDecodeInfo& decode() const { return decode_; }
  const ReconstructionResult& result() const { return result_; }
  size_t scans() const { return scans_; }  // placed in pass 2
  // Pass 1 read the session (a failure after it is the poses': options, or
  // a session without odometry).
  bool decoded() const { return decoded_; }
  // A box that holds every point pass 2 can place: the poses' positions
  // widened by the longest range plus the lidar's offset from the body
  // (and 1 mm for float rounding). The LAS writer needs its extent first.
  void PointBounds(double min[3], double max[3]) const;
  // After pass 1: at most this many points pass 2 places (0: not known).
  // Pass 2 places at most one point a lidar sample, and an X4 packet holds
  // its samples in 2 bytes each after a 10-byte header
  // (docs/device-codecs.md): the lidar's bytes over 2, which pass 1 counts
  // without decoding them, exceed the points by about a tenth (40 samples
  // a packet) plus the samples without a return. An imported bag's
  // (measurement session's) records are not counted: 0. A caller that
  // keeps every point reserves this and is never reallocated (the copy of
  // a doubling held 1.5 times the points at the peak); the tail a bound
  // leaves unused is never written, so never resident.
  size_t PointBound() const { return decode_.telemetry.device_bytes[0] / 2; }
  // After pass 2: the poses, moved out (result().poses is then empty).
  PoseBuffer TakePoses() { return std::move(result_.poses); }
  // Motion records and poses held, bytes (what pass 1 keeps for pass 2).
  size_t held_bytes() const;

  // The wheel and IMU records of pass 1, kept when set before it (the app
  // keeps them with an opened session; the CLI does not need them).
  void set_keep_motion(bool keep) { keep_motion_ = keep; }
  SensorLog TakeMotion() { return std::move(motion_); }

  // Pass 2. Fills result().stats and the gaps' dropped-sample counts. The
  // sink runs on a thread of PlacePoints' own (header comment).
  Status PlacePoints(const PointSink& sink, const DecodeProgress& progress = nullptr);

 private:
  std::string dir_;
  FramesLoadOptions frames_options_;
  ReconstructionOptions options_;
  SessionDecodeInfo decode_;
  SensorLog motion_;
  ReconstructionResult result_;
  size_t scans_ = 0;
  bool decoded_ = false;
  bool keep_motion_ = false;
};

}  // namespace sweepscan::hardware

#endif  // SWEEPSCAN_HARDWARE_STATION_SESSION_STREAM_H_
