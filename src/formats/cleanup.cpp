#include "moa/formats/cleanup.hpp"

#include <signal.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <utility>

namespace moa::io {
namespace {

constexpr int kSlots = 256;
constexpr std::size_t kMaxPath = 4096;

// A slot is free (0), being filled (1) or holds a path (2). The handler reads
// only slots in state 2, whose path is complete; the order of registration
// (a sequence number) lets it remove a directory's files before the directory.
struct Slot {
  std::atomic<int> state{0};
  std::atomic<unsigned long> order{0};
  char path[kMaxPath] = {};
};
std::array<Slot, kSlots> g_slots;
std::atomic<unsigned long> g_next_order{1};

void write_text(const char* text) {
  const std::size_t n = std::strlen(text);
  ssize_t ignored = ::write(STDERR_FILENO, text, n);
  (void)ignored;
}

// Every signal whose default action ends the process, bar the faults of
// the program itself (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGTRAP,
// SIGSYS) and SIGKILL: a lost ssh session (SIGHUP), a reader gone (SIGPIPE),
// a file size limit (SIGXFSZ), a CPU limit (SIGXCPU), a timer.
constexpr std::array<int, 12> kSignals{SIGHUP,  SIGINT,  SIGQUIT, SIGPIPE,   SIGALRM, SIGTERM,
                                       SIGUSR1, SIGUSR2, SIGXCPU, SIGVTALRM, SIGPROF, SIGXFSZ};

const char* signal_name(int signal) {
  switch (signal) {
    case SIGHUP:
      return "SIGHUP";
    case SIGINT:
      return "SIGINT";
    case SIGQUIT:
      return "SIGQUIT";
    case SIGPIPE:
      return "SIGPIPE";
    case SIGALRM:
      return "SIGALRM";
    case SIGTERM:
      return "SIGTERM";
    case SIGUSR1:
      return "SIGUSR1";
    case SIGUSR2:
      return "SIGUSR2";
    case SIGXCPU:
      return "SIGXCPU";
    case SIGVTALRM:
      return "SIGVTALRM";
    case SIGPROF:
      return "SIGPROF";
    case SIGXFSZ:
      return "SIGXFSZ";
    default:
      return "a signal";
  }
}

extern "C" void on_signal(int signal) {
  // Newest first: repeatedly the registered path with the largest order.
  unsigned long below = ~0ul;
  for (;;) {
    int best = -1;
    unsigned long best_order = 0;
    for (int i = 0; i < kSlots; ++i) {
      if (g_slots[i].state.load() != 2) continue;
      const unsigned long order = g_slots[i].order.load();
      if (order < below && order > best_order) {
        best = i;
        best_order = order;
      }
    }
    if (best < 0) break;
    below = best_order;
    if (::unlink(g_slots[best].path) != 0 && (errno == EISDIR || errno == EPERM)) {
      ::rmdir(g_slots[best].path);
    }
  }
  write_text("moa: interrupted by ");
  write_text(signal_name(signal));
  write_text("; temporary files removed\n");
  ::_exit(128 + signal);
}

}  // namespace

TemporaryPath::TemporaryPath(const std::filesystem::path& path) {
  const std::string& text = path.native();
  if (text.size() >= kMaxPath) return;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (!g_slots[i].state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_slots[i].path, text.c_str(), text.size() + 1);
    g_slots[i].order.store(g_next_order.fetch_add(1));
    g_slots[i].state.store(2);
    slot_ = i;
    return;
  }
}

TemporaryPath::~TemporaryPath() { release(); }

TemporaryPath::TemporaryPath(TemporaryPath&& other) noexcept
    : slot_(std::exchange(other.slot_, -1)) {}

TemporaryPath& TemporaryPath::operator=(TemporaryPath&& other) noexcept {
  if (this != &other) {
    release();
    slot_ = std::exchange(other.slot_, -1);
  }
  return *this;
}

void TemporaryPath::release() {
  if (slot_ < 0) return;
  g_slots[static_cast<std::size_t>(slot_)].state.store(0);
  slot_ = -1;
}

void remove_temporaries_on_signal() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  // The other signals wait while the handler runs: one clean-up at a time.
  for (const int signal : kSignals) sigaddset(&action.sa_mask, signal);
  for (const int signal : kSignals) {
    // One ignored by whoever started moa (nohup's SIGHUP) stays ignored.
    struct sigaction old {};
    if (sigaction(signal, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    sigaction(signal, &action, nullptr);
  }
}

}  // namespace moa::io
