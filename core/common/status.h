// Expected failures (a corrupt file, an unsolvable problem, bad input) are
// returned as a Status with a message that says where and why. Broken
// invariants are programming errors and assert instead.
#ifndef SWEEPSCAN_CORE_COMMON_STATUS_H_
#define SWEEPSCAN_CORE_COMMON_STATUS_H_

#include <string>
#include <utility>

namespace sweepscan {

class Status {
 public:
  Status() = default;
  static Status Ok() { return Status(); }
  static Status Error(std::string message) { return Status(std::move(message)); }

  bool ok() const { return !failed_; }
  const std::string& message() const { return message_; }

 private:
  explicit Status(std::string message) : failed_(true), message_(std::move(message)) {}
  bool failed_ = false;
  std::string message_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_STATUS_H_
