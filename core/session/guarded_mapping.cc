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
// lowest failed address + 1 (0: none). `seq` is odd while the owner changes
// the range (a seqlock): the handler of another thread's fault must not
// take one mapping's begin with the next one's end.
struct Slot {
  std::atomic<bool> used{false};  // claimed by a mapping
  std::atomic<uint32_t> seq{0};
  std::atomic<uintptr_t> begin{0};
  std::atomic<uintptr_t> end{0};
  std::atomic<uintptr_t> failed{0};
};
Slot g_slots[GuardedMapping::kMaxMappings];
struct sigaction g_previous;
std::once_flag g_installed;
uintptr_t g_page = 4096;  // set before the handler is installed

// The owner's side of the seqlock: `change` between two bumps of seq.
template <typename F>
void Publish(Slot* slot, F change) {
  const uint32_t s = slot->seq.load(std::memory_order_relaxed);
  slot->seq.store(s + 1, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  change();
  slot->seq.store(s + 2, std::memory_order_release);
}

// The slot whose range holds `at`, read consistently; null if none.
Slot* SlotHolding(uintptr_t at, uintptr_t* end) {
  for (Slot& slot : g_slots) {
    const uint32_t before = slot.seq.load(std::memory_order_acquire);
    if ((before & 1) != 0) continue;  // changing: not a range being read
    const uintptr_t b = slot.begin.load(std::memory_order_relaxed);
    const uintptr_t e = slot.end.load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (slot.seq.load(std::memory_order_relaxed) != before) continue;
    if (b != 0 && at >= b && at < e) {
      *end = e;
      return &slot;
    }
  }
  return nullptr;
}

void ForwardToPrevious(int signal, siginfo_t* info, void* context) {
  if ((g_previous.sa_flags & SA_SIGINFO) != 0 && g_previous.sa_sigaction != nullptr) {
    g_previous.sa_sigaction(signal, info, context);
    return;
  }
  const bool sent = info->si_code <= 0;  // kill or sigqueue, not a fault
  if (g_previous.sa_handler == SIG_IGN && sent) return;
  if (g_previous.sa_handler != SIG_DFL && g_previous.sa_handler != SIG_IGN &&
      g_previous.sa_handler != nullptr) {
    g_previous.sa_handler(signal);
    return;
  }
  // The default action: a fault recurs as the handler returns and ends the
  // process then; a sent or asynchronous one (BUS_MCEERR_AO) is raised.
  struct sigaction dfl;
  std::memset(&dfl, 0, sizeof(dfl));
  dfl.sa_handler = SIG_DFL;
  sigaction(SIGBUS, &dfl, nullptr);
  if (sent || info->si_code == BUS_MCEERR_AO) raise(signal);
}

void OnSigbus(int signal, siginfo_t* info, void* context) {
  const int saved_errno = errno;  // the interrupted code may be about to read it
  // Only a read of a page that cannot be supplied (past the end of the
  // file, or an I/O error) is a reader's failure.
  const bool fault =
      info->si_code == BUS_ADRERR || info->si_code == BUS_OBJERR || info->si_code == BUS_MCEERR_AR;
  const uintptr_t at = reinterpret_cast<uintptr_t>(info->si_addr);
  uintptr_t end = 0;
  Slot* slot = fault ? SlotHolding(at, &end) : nullptr;
  // Zeros from the failed page to the end of the range in one mapping (one
  // signal, not one a page as a reader scans on); the faulting read is then
  // re-executed. Should that fail, the fault is not ours to absorb.
  const uintptr_t base = at / g_page * g_page;
  if (slot != nullptr &&
      mmap(reinterpret_cast<void*>(base), (end - base + g_page - 1) / g_page * g_page, PROT_READ,
           MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1, 0) != MAP_FAILED) {
    uintptr_t seen = slot->failed.load(std::memory_order_relaxed);
    while ((seen == 0 || at + 1 < seen) &&
           !slot->failed.compare_exchange_weak(seen, at + 1, std::memory_order_release)) {
    }
  } else {
    ForwardToPrevious(signal, info, context);
  }
  errno = saved_errno;
}

void Install() {
  g_page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_sigaction = OnSigbus;
  action.sa_flags = SA_SIGINFO | SA_ONSTACK;
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
  const uintptr_t begin = reinterpret_cast<uintptr_t>(data_);
  for (int i = 0; i < kMaxMappings; ++i) {
    bool free = false;
    if (!g_slots[i].used.compare_exchange_strong(free, true, std::memory_order_acquire)) continue;
    Slot* slot = &g_slots[i];
    Publish(slot, [&] {
      slot->end.store(begin + size_, std::memory_order_relaxed);
      slot->failed.store(0, std::memory_order_relaxed);
      slot->begin.store(begin, std::memory_order_relaxed);
    });
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
  const uintptr_t page =
      (g_slots[slot_].failed.load(std::memory_order_acquire) - 1) / g_page * g_page;
  const uintptr_t begin = reinterpret_cast<uintptr_t>(data_);
  return page >= begin ? page - begin : 0;
}

std::string GuardedMapping::FailureMessage() const {
  return path_ + ": bytes from " + std::to_string(failed_offset()) +
         " on could not be read (its disk failed, or the file shrank, while it was read)";
}

void GuardedMapping::Unmap() {
  if (slot_ >= 0) {
    // Out of the handler's sight before the pages go (munmap after).
    Slot* slot = &g_slots[slot_];
    Publish(slot, [&] { slot->begin.store(0, std::memory_order_relaxed); });
    slot->used.store(false, std::memory_order_release);
    slot_ = -1;
  }
  if (data_ != nullptr) ::munmap(data_, size_);
  data_ = nullptr;
  size_ = 0;
}

GuardedMapping::~GuardedMapping() { Unmap(); }

}  // namespace sweepscan
