// CDR (OMG Common Data Representation, XCDR1 as ROS 2's rmw writes it)
// decoding of the four ROS 2 messages sweepscan reads (docs/ros-bags.md,
// "ROS 2 bags"), and the decode-and-dispatch step both ROS 2 storage readers
// (MCAP, sqlite3) share.
//
// A serialized message starts with a 4-byte encapsulation header: bytes 0-1
// are the representation identifier, 00 00 = CDR_BE, 00 01 = CDR_LE (any
// other, e.g. XCDR2's 00 07, is refused), bytes 2-3 are options (ignored).
// Primitives are aligned to their size relative to byte 4 (the first byte
// after the header); strings are uint32 length including the NUL, then the
// bytes and the NUL; sequences are uint32 element count, then the elements;
// fixed arrays (float64[36]) have no count.
//
// Every read is bounds-checked. Failures name the message, the field and the
// byte offset from the start of the buffer (header included), e.g.
//   LaserScan: ranges: sequence of 4294967295 elements needs 17179869180
//   bytes, 12 left at byte 48
// A count is checked against the bytes left before anything is allocated.
// Bytes after the last field are ignored (rmw may pad to a multiple of 4).
//
// Thread: pure functions; CdrReader is used from one thread.
#ifndef SWEEPSCAN_CORE_IO_ROS2_CDR_H_
#define SWEEPSCAN_CORE_IO_ROS2_CDR_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"

namespace sweepscan::io {

// Sequential reader over one CDR buffer. `message` names the message in
// errors ("LaserScan"); each read names its field.
class CdrReader {
 public:
  CdrReader(const uint8_t* data, size_t size, const char* message)
      : data_(data), size_(size), message_(message) {}

  // Reads and checks the encapsulation header; must be called first.
  Status ReadEncapsulation();

  Status ReadInt32(const char* field, int32_t* v);
  Status ReadUint32(const char* field, uint32_t* v);
  Status ReadFloat32(const char* field, float* v);
  Status ReadFloat64(const char* field, double* v);
  Status ReadFloat64s(const char* field, double* v, size_t n);  // fixed array
  Status ReadString(const char* field, std::string* s);
  // Reads a sequence's element count and checks that `count * min_element_bytes`
  // bytes are left.
  Status ReadSequenceCount(const char* field, size_t min_element_bytes, uint32_t* count);
  Status ReadFloat32Sequence(const char* field, std::vector<float>* v);

  bool big_endian() const { return big_endian_; }
  size_t offset() const { return pos_; }  // from the start of the buffer

 private:
  // Skips padding to `alignment` (relative to byte 4) and checks that `n`
  // more bytes are there.
  Status Prepare(const char* field, size_t alignment, size_t n);
  Status Error(const char* field, const std::string& why) const;
  uint32_t Load32();  // at pos_, advancing; byte order of the stream
  uint64_t Load64();

  const uint8_t* data_;
  size_t size_;
  const char* message_;
  size_t pos_ = 0;
  bool big_endian_ = false;
};

// Decoders of whole serialized messages (encapsulation header included).
// On failure *m is left partly filled and must not be used.
Status DecodeCdrLaserScan(const uint8_t* data, size_t n, RosLaserScan* m);
Status DecodeCdrOdometry(const uint8_t* data, size_t n, RosOdometry* m);
Status DecodeCdrImu(const uint8_t* data, size_t n, RosImu* m);
Status DecodeCdrTfMessage(const uint8_t* data, size_t n, RosTfMessage* m);

// What a ROS 2 reader reports besides its Status: things it tolerated, e.g. a
// torn tail ("file ends at byte 20817 inside a Chunk record ...: the 12
// messages before it were read"), a summary section it could not use, or a
// decodable type in an encoding other than CDR.
struct Ros2ReadReport {
  std::vector<std::string> warnings;
  bool torn_tail = false;  // the file ended inside a record (or lacks its footer)
  // Something of the file was damaged and read past (a torn tail, a
  // summary whose CRC or offsets fail, a damaged sqlite page); warnings of
  // an intact file (a topic in another encoding, messages back in time) do
  // not set it.
  bool damaged = false;
  // An MCAP read in log-time order (chunks out of it) at its fullest: the
  // chunks whose messages were waiting at once, and those messages. What
  // bounds its memory; tests check it stays the chunks overlapping in time.
  uint64_t peak_chunks_held = 0;
  uint64_t peak_messages_held = 0;
};

// Decodes one CDR message of `kind` and hands it to the sink. A message that
// does not decode goes to sink->OnUndecodable (counted in
// stats->messages_undecodable); one that does to the sink's On...() (counted
// in messages_read). Returns false when the sink asked to stop.
bool DispatchCdrMessage(RosMessageKind kind, const RosMessageInfo& info, const uint8_t* data,
                        size_t n, RosMessageSink* sink, RosReadStats* stats);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS2_CDR_H_
