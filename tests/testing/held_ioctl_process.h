// A process started with some of its system calls held by the kernel
// (seccomp user notification) until the test lets them go: how the robotd
// tests make a serial port open slowly or a USB-serial adapter wedge at
// the stop, which pseudo-terminals never do. Linux only; where the kernel
// refuses the filter, `error` says so and the test skips.
#ifndef SWEEPSCAN_TESTS_TESTING_HELD_IOCTL_PROCESS_H_
#define SWEEPSCAN_TESTS_TESTING_HELD_IOCTL_PROCESS_H_

#include <fcntl.h>
#include <linux/audit.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <string>
#include <vector>

#include "tests/testing/read_available.h"

namespace sweepscan::testing {

// A process whose ioctl(`request`) calls the kernel holds: a seccomp filter
// sends each to a listener (the test's), and the call waits until the
// listener answers (Continue()) or is closed (ReleaseHeldCalls(): ENOSYS).
// With TCSBRK its tcdrain never returns, as on a wedged USB-serial adapter
// (a pseudo-terminal's returns at once: it has no queue to wait for); with
// TIOCEXCL (which QSerialPort's open makes) its serial ports open slowly.
//
// With HeldSyscall, every call of that system call is held instead: with
// fdatasync, the process's disk syncs take as long as the test holds them,
// as on a busy laptop disk or a slow USB stick.
struct HeldSyscall {
  long nr;
};

struct HeldIoctlProcess {
  pid_t pid = -1;
  int listener = -1;  // The seccomp listener: held calls stay held while it is open.
  int output = -1;    // The process's stdout and stderr (non-blocking).
  std::string error;  // Why it did not start.
  int status = -1;    // waitpid's, once it has exited.

  HeldIoctlProcess(const std::vector<std::string>& command, uint32_t request) {
    Start(command, __NR_ioctl, true, request);
  }
  HeldIoctlProcess(const std::vector<std::string>& command, HeldSyscall call) {
    Start(command, call.nr, false, 0);
  }

 private:
  // Holds system call `nr`; `match_request`: only when its second argument's
  // low 32 bits are `request` (ioctl's).
  void Start(const std::vector<std::string>& command, long nr, bool match_request,
             uint32_t request) {
#if defined(__x86_64__)
    constexpr uint32_t kArch = AUDIT_ARCH_X86_64;
#elif defined(__aarch64__)
    constexpr uint32_t kArch = AUDIT_ARCH_AARCH64;
#else
    error = "no seccomp filter for this architecture";
    return;
#endif
    sock_filter filter[] = {
        BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, arch)),
        BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, kArch, 1, 0),
        BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
        BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, nr)),
        BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, static_cast<uint32_t>(nr), 1, 0),
        BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
        // The request's low 32 bits (little-endian).
        BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, args[1])),
        BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, request, 0, 1),
        BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_USER_NOTIF),
        BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
    };
    // Any call of `nr`: held where the request would be loaded.
    if (!match_request) filter[6] = BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_USER_NOTIF);
    sock_fprog program{static_cast<unsigned short>(std::size(filter)), filter};
    std::vector<char*> argv;  // Made before fork(): the child only makes system calls.
    for (const std::string& a : command) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    int channel[2], pipe[2];
    if (::socketpair(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0, channel) != 0 ||
        ::pipe2(pipe, O_CLOEXEC) != 0) {
      error = std::strerror(errno);
      return;
    }
    pid = ::fork();
    if (pid == 0) {
      ::dup2(pipe[1], 1);
      ::dup2(pipe[1], 2);
      ::prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0);
      const int fd = static_cast<int>(::syscall(SYS_seccomp, SECCOMP_SET_MODE_FILTER,
                                                SECCOMP_FILTER_FLAG_NEW_LISTENER, &program));
      if (fd < 0) ::_exit(126);
      char byte = 0;
      iovec io{&byte, 1};
      alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
      msghdr message{};
      message.msg_iov = &io;
      message.msg_iovlen = 1;
      message.msg_control = control;
      message.msg_controllen = sizeof(control);
      cmsghdr* header = CMSG_FIRSTHDR(&message);
      header->cmsg_level = SOL_SOCKET;
      header->cmsg_type = SCM_RIGHTS;
      header->cmsg_len = CMSG_LEN(sizeof(int));
      std::memcpy(CMSG_DATA(header), &fd, sizeof(int));
      if (::sendmsg(channel[1], &message, 0) != 1) ::_exit(126);
      ::close(fd);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(channel[1]);
    ::close(pipe[1]);
    output = pipe[0];
    ::fcntl(output, F_SETFL, O_NONBLOCK);
    char byte = 0;
    iovec io{&byte, 1};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
    msghdr message{};
    message.msg_iov = &io;
    message.msg_iovlen = 1;
    message.msg_control = control;
    message.msg_controllen = sizeof(control);
    if (pid > 0 && ::recvmsg(channel[0], &message, 0) == 1) {
      const cmsghdr* header = CMSG_FIRSTHDR(&message);
      if (header != nullptr && header->cmsg_type == SCM_RIGHTS) {
        std::memcpy(&listener, CMSG_DATA(header), sizeof(int));
      }
    }
    ::close(channel[0]);
    if (listener < 0) error = "the kernel refused the seccomp filter (user notification)";
  }

 public:
  ~HeldIoctlProcess() {
    ReleaseHeldCalls();
    if (pid > 0 && !Exited()) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
    }
    if (output >= 0) ::close(output);
  }
  void ReleaseHeldCalls() {
    if (listener >= 0) ::close(listener);
    listener = -1;
  }
  // A call is held.
  bool Holding() const {
    pollfd ready{listener, POLLIN, 0};
    return listener >= 0 && ::poll(&ready, 1, 0) == 1 && (ready.revents & POLLIN) != 0;
  }
  // Lets the calls held so far go on; the number let go.
  int Continue() {
    int n = 0;
    while (Holding()) {
      seccomp_notif call{};
      if (::ioctl(listener, SECCOMP_IOCTL_NOTIF_RECV, &call) != 0) break;
      seccomp_notif_resp answer{};
      answer.id = call.id;
      answer.flags = SECCOMP_USER_NOTIF_FLAG_CONTINUE;
      // ENOENT: the call was interrupted (a signal) and will be made again.
      if (::ioctl(listener, SECCOMP_IOCTL_NOTIF_SEND, &answer) == 0) ++n;
    }
    return n;
  }
  bool Exited() {
    if (status != -1) return true;
    return pid > 0 && ::waitpid(pid, &status, WNOHANG) == pid;
  }
  std::string Read() {
    std::string text;
    ReadAvailable(output, &text);
    return text;
  }
};

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_HELD_IOCTL_PROCESS_H_
