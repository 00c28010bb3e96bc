#include "core/session/guarded_mapping.h"

#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>

namespace sweepscan {
namespace {

// A guarded range: [begin, end) while in use (begin 0 when free), and the
// lowest failed address + 1 (0: none).
struct Slot {
  std::atomic<bool> used{false};  // claimed by a mapping
  std::atomic<uintptr_t> begin{0};
  std::atomic<uintptr_t> end{0};
  std::atomic<uintptr_t> failed{0};
};
Slot g_slots[GuardedMapping::kMaxMappings];
struct sigaction g_previous;
std::once_flag g_installed;
uintptr_t g_page = 4096;  // set before the handler is installed

void OnSigbus(int signal, siginfo_t* info, void* context) {
  const uintptr_t at = reinterpret_cast<uintptr_t>(info->si_addr);
  for (Slot& slot : g_slots) {
    const uintptr_t begin = slot.begin.load(std::memory_order_acquire);
    if (begin == 0 || at < begin || at >= slot.end.load(std::memory_order_acquire)) continue;
    const uintptr_t page = g_page;
    void* base = reinterpret_cast<void*>(at / page * page);
    // Zeros over the failed page; the faulting read is then re-executed.
    if (mmap(base, page, PROT_READ, MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1, 0) == MAP_FAILED)
      break;
    uintptr_t seen = slot.failed.load(std::memory_order_relaxed);
    while ((seen == 0 || at + 1 < seen) &&
           !slot.failed.compare_exchange_weak(seen, at + 1, std::memory_order_release)) {
    }
    return;
  }
  // Not ours: whatever handled SIGBUS before, or the default (the process
  // ends with the fault re-raised as the handler returns).
  if ((g_previous.sa_flags & SA_SIGINFO) != 0 && g_previous.sa_sigaction != nullptr) {
    g_previous.sa_sigaction(signal, info, context);
    return;
  }
  if (g_previous.sa_handler != SIG_DFL && g_previous.sa_handler != SIG_IGN &&
      g_previous.sa_handler != nullptr) {
    g_previous.sa_handler(signal);
    return;
  }
  struct sigaction dfl;
  std::memset(&dfl, 0, sizeof(dfl));
  dfl.sa_handler = SIG_DFL;
  sigaction(SIGBUS, &dfl, nullptr);
  if (info->si_code <= 0) raise(signal);  // sent (kill), not a fault that recurs
}

void Install() {
  g_page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_sigaction = OnSigbus;
  action.sa_flags = SA_SIGINFO;
  sigemptyset(&action.sa_mask);
  sigaction(SIGBUS, &action, &g_previous);
}

}  // namespace

Status GuardedMapping::Map(int fd, const std::string& path) {
  Unmap();
  path_ = path;
  struct stat st;
  if (::fstat(fd, &st) != 0) return Status::Error(path + ": cannot stat: " + std::strerror(errno));
  size_ = static_cast<size_t>(st.st_size);
  if (size_ == 0) return Status::Ok();
  std::call_once(g_installed, Install);
  void* map = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
  if (map == MAP_FAILED) {
    size_ = 0;
    return Status::Error(path + ": cannot map for reading: " + std::strerror(errno));
  }
  data_ = static_cast<uint8_t*>(map);
  for (int i = 0; i < kMaxMappings; ++i) {
    bool free = false;
    if (!g_slots[i].used.compare_exchange_strong(free, true, std::memory_order_acquire)) continue;
    // Its end and failure first, then its begin, which the handler reads
    // first, to publish it.
    g_slots[i].end.store(reinterpret_cast<uintptr_t>(data_) + size_, std::memory_order_relaxed);
    g_slots[i].failed.store(0, std::memory_order_relaxed);
    g_slots[i].begin.store(reinterpret_cast<uintptr_t>(data_), std::memory_order_release);
    slot_ = i;
    break;
  }
  return Status::Ok();
}

bool GuardedMapping::failed() const {
  return slot_ >= 0 && g_slots[slot_].failed.load(std::memory_order_acquire) != 0;
}

size_t GuardedMapping::failed_offset() const {
  if (!failed()) return size_;
  const uintptr_t at = g_slots[slot_].failed.load(std::memory_order_acquire) - 1;
  return (at / g_page * g_page) - reinterpret_cast<uintptr_t>(data_);
}

std::string GuardedMapping::FailureMessage() const {
  return path_ + ": bytes from " + std::to_string(failed_offset()) +
         " on could not be read (its disk failed, or the file shrank, while it was read)";
}

void GuardedMapping::Unmap() {
  if (slot_ >= 0) {
    g_slots[slot_].begin.store(0, std::memory_order_release);
    g_slots[slot_].used.store(false, std::memory_order_release);
    slot_ = -1;
  }
  if (data_ != nullptr) ::munmap(data_, size_);
  data_ = nullptr;
  size_ = 0;
}

GuardedMapping::~GuardedMapping() { Unmap(); }

}  // namespace sweepscan
