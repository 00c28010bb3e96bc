#include "hardware/agent/telemetry_buffer.h"

#include <algorithm>
#include <cmath>

#include <cstring>

namespace sweepscan {
namespace hardware {
namespace {

constexpr size_t kHeader = 22;
constexpr size_t kBlockBytes = 64 * 1024;

// In-memory records: host byte order.
template <typename T>
void Put(T v, std::vector<uint8_t>* out) {
  uint8_t b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out->insert(out->end(), b, b + sizeof(T));
}
template <typename T>
T Get(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

}  // namespace

TelemetryBuffer::TelemetryBuffer(Duration keep, size_t max_bytes, Time start)
    : keep_(keep.count() > 0 ? keep : Duration::zero()), max_bytes_(max_bytes) {
  if (max_bytes_ == 0 && enabled()) {
    max_bytes_ = static_cast<size_t>(std::ceil(kTelemetryBufferBytesPerSecond * ToSeconds(keep_)));
  }
  dropped_up_to_.fill(start);
}

uint64_t TelemetryBuffer::Push(uint8_t device, Time receive_time, const uint8_t* data, size_t n,
                               Time now) {
  const uint64_t serial = next_serial_++;
  if (!enabled() || device < 1 || device > 3) return serial;
  const size_t need = kHeader + n;
  if (blocks_.empty() || blocks_.back().data.size() + need > blocks_.back().data.capacity()) {
    Block block;
    block.data.reserve(std::max(kBlockBytes, need));
    bytes_ += block.data.capacity();
    blocks_.push_back(std::move(block));
  }
  Block& b = blocks_.back();
  Put<uint64_t>(serial, &b.data);
  Put<int64_t>(ToNanoseconds(receive_time), &b.data);
  Put<uint32_t>(static_cast<uint32_t>(n), &b.data);
  b.data.push_back(device);
  b.data.push_back(0);
  b.data.insert(b.data.end(), data, data + n);
  b.newest = std::max(b.newest, receive_time);
  Evict(now);
  peak_bytes_ = std::max(peak_bytes_, bytes_);
  return serial;
}

void TelemetryBuffer::Evict(Time now) {
  // Never the block being filled: what was just read must survive.
  while (blocks_.size() > 1 &&
         (bytes_ > max_bytes_ || now - blocks_.front().newest > keep_)) {
    DropFront();
  }
}

void TelemetryBuffer::DropFront() {
  const Block& b = blocks_.front();
  for (size_t pos = 0; pos + kHeader <= b.data.size();) {
    const Time t = TimeFromNanoseconds(Get<int64_t>(b.data.data() + pos + 8));
    const uint32_t n = Get<uint32_t>(b.data.data() + pos + 16);
    const uint8_t device = b.data[pos + 20];
    dropped_up_to_[device - 1] = std::max(dropped_up_to_[device - 1], t);
    pos += kHeader + n;
  }
  bytes_ -= b.data.capacity();
  blocks_.pop_front();
}

template <typename F>
void TelemetryBuffer::ForEach(F&& f) const {
  for (const Block& b : blocks_) {
    for (size_t pos = 0; pos + kHeader <= b.data.size();) {
      Piece p;
      p.serial = Get<uint64_t>(b.data.data() + pos);
      p.receive_time = TimeFromNanoseconds(Get<int64_t>(b.data.data() + pos + 8));
      p.size = Get<uint32_t>(b.data.data() + pos + 16);
      p.device = b.data[pos + 20];
      p.data = b.data.data() + pos + kHeader;
      f(p);
      pos += kHeader + p.size;
    }
  }
}

size_t TelemetryBuffer::chunks() const {
  size_t n = 0;
  ForEach([&n](const Piece&) { ++n; });
  return n;
}

void TelemetryBuffer::CollectAfter(const TelemetryResume& resume, uint64_t late_before,
                                   const std::function<void(const Piece&)>& emit,
                                   std::array<bool, 3>* pending_break) const {
  // Bytes still to skip of chunks stamped exactly at a device's after_time
  // (one read split into several chunks shares its time).
  std::array<uint64_t, 3> skip_at_time{};
  for (int d = 0; d < 3; ++d) {
    const TelemetryResumePosition& pos = resume.devices[d];
    skip_at_time[d] = pos.have ? pos.bytes_at_time : 0;
    // Lost: the client never had this device's bytes (a new clock epoch),
    // or chunks after its position were dropped before it came back.
    (*pending_break)[d] = LostAfter(static_cast<uint8_t>(d + 1), pos);
  }
  ForEach([&](const Piece& chunk) {
    const int d = chunk.device - 1;
    const TelemetryResumePosition& pos = resume.devices[d];
    Piece p = chunk;
    if (pos.have) {
      if (p.receive_time < pos.after_time) return;
      if (p.receive_time == pos.after_time) {
        if (skip_at_time[d] >= p.size) {
          skip_at_time[d] -= p.size;
          return;
        }
        p.data += skip_at_time[d];
        p.size -= skip_at_time[d];
        skip_at_time[d] = 0;
      }
    }
    p.flags = p.serial < late_before ? kTelemetryLate : 0;
    if ((*pending_break)[d]) {
      p.flags |= kTelemetryBreak;
      (*pending_break)[d] = false;
    }
    emit(p);
  });
}

void TelemetryBuffer::CollectFrom(uint64_t from,
                                  const std::function<void(const Piece&)>& emit) const {
  ForEach([&](const Piece& chunk) {
    if (chunk.serial >= from) emit(chunk);
  });
}

}  // namespace hardware
}  // namespace sweepscan
