// Reading what a non-blocking descriptor holds now (a pty's master, the far
// end of a serial link in the agent's tests), without waiting.
#ifndef SWEEPSCAN_TESTS_TESTING_READ_AVAILABLE_H_
#define SWEEPSCAN_TESTS_TESTING_READ_AVAILABLE_H_

#include <unistd.h>

#include <cstddef>
#include <string>

namespace sweepscan::testing {

// Bytes waiting on the non-blocking `fd`, appended to *into; the count read.
inline size_t ReadAvailable(int fd, std::string* into) {
  char buffer[4096];
  size_t total = 0;
  ssize_t n;
  while ((n = ::read(fd, buffer, sizeof(buffer))) > 0) {
    into->append(buffer, static_cast<size_t>(n));
    total += static_cast<size_t>(n);
  }
  return total;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_READ_AVAILABLE_H_
