// The agent's memory of recent device bytes, so that a workstation whose link
// stalled or dropped gets what it missed once it reconnects
// (docs/robot-agent.md, "Buffering across outages"; docs/protocol.md,
// "TelemetryResume").
//
// Every chunk the agent reads from a device port is kept here, whether or not
// it also went out on the link: bytes written into a TCP connection that then
// dies are lost in the kernel's buffers without the agent knowing, so what
// counts is what the workstation says it holds. A chunk is a record packed
// into 64 KiB blocks:
//
//   serial u64 | receive_time i64 (robot clock, ns) | n u32 | device u8 | pad u8 | n bytes
//
// (22 bytes of header). Whole blocks are dropped from the front once their
// newest chunk is older than `keep`, or while the blocks hold more than
// `max_bytes`, so the memory is bounded by max_bytes + one block whatever the
// link does. The default bound: the three serial lines at full rate
// (X4 128 000 baud + HI219 115 200 + motor board 115 200, 10 bits a byte:
// 35 840 B/s) plus a header per read at up to 1 000 reads a second per
// device (66 000 B/s) is 101 840 B/s; with a quarter more for the blocks'
// slack, 128 KiB/s x keep: 1.31 MB for 10 s.
//
// Not thread-safe: lives in AgentCore, on the agent's I/O thread.
#ifndef SWEEPSCAN_HARDWARE_AGENT_TELEMETRY_BUFFER_H_
#define SWEEPSCAN_HARDWARE_AGENT_TELEMETRY_BUFFER_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <vector>

#include "core/common/time.h"
#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {

// Bytes a second the default bound allows for (see above).
inline constexpr double kTelemetryBufferBytesPerSecond = 128.0 * 1024.0;

class TelemetryBuffer {
 public:
  // keep <= 0 disables the buffer (Push keeps nothing). max_bytes 0 = the
  // default bound for `keep`. Chunks read before `start` (the agent's start)
  // are unknown: a resume from before it reports a break.
  TelemetryBuffer(Duration keep, size_t max_bytes, Time start);

  bool enabled() const { return keep_.count() > 0; }
  // Keeps a chunk; returns its serial number (0, 1, 2, ... over the agent's life).
  uint64_t Push(uint8_t device, Time receive_time, const uint8_t* data, size_t n, Time now);
  // Drops blocks older than keep (Push does it too).
  void Evict(Time now);
  uint64_t next_serial() const { return next_serial_; }

  // One chunk to send: a view into the buffer (valid until the next Push /
  // Evict) and its flags (kTelemetryLate for serial < late_before,
  // kTelemetryBreak on the first chunk of a device whose bytes after the
  // resume point were dropped).
  struct Piece {
    uint64_t serial = 0;
    uint8_t device = 0;
    Time receive_time;
    const uint8_t* data = nullptr;
    size_t size = 0;
    uint8_t flags = 0;
  };
  // Every kept chunk after the client's position per device (a
  // TelemetryResume), in the order they were read; chunks with serial >=
  // late_before are not late. For a device without a position (have =
  // false) everything kept is sent and the first chunk marked as a break.
  // lost[d] says whether bytes after device d's position were dropped (the
  // break is then reported even if nothing of d is kept: *pending_break).
  void CollectAfter(const TelemetryResume& resume, uint64_t late_before,
                    const std::function<void(const Piece&)>& emit,
                    std::array<bool, 3>* pending_break) const;
  // Every kept chunk with serial >= from (not late), in order.
  void CollectFrom(uint64_t from, const std::function<void(const Piece&)>& emit) const;
  // Whether bytes of device (1..3) after the position were dropped.
  bool LostAfter(uint8_t device, const TelemetryResumePosition& position) const {
    return !position.have || dropped_up_to_[device - 1] > position.after_time;
  }

  size_t bytes() const { return bytes_; }            // Block capacity held now.
  size_t peak_bytes() const { return peak_bytes_; }  // Largest bytes() so far.
  size_t max_bytes() const { return max_bytes_; }
  size_t chunks() const;
  Duration keep() const { return keep_; }

 private:
  struct Block {
    std::vector<uint8_t> data;
    Time newest;
  };
  template <typename F>
  void ForEach(F&& f) const;
  void DropFront();

  Duration keep_;
  size_t max_bytes_;
  std::deque<Block> blocks_;
  size_t bytes_ = 0;
  size_t peak_bytes_ = 0;
  uint64_t next_serial_ = 0;
  // Per device: the newest receive time of a chunk that was dropped (or the
  // agent's start: nothing before it was ever kept).
  std::array<Time, 3> dropped_up_to_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_AGENT_TELEMETRY_BUFFER_H_
