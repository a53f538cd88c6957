#include "stop_signals.hpp"

#include <pthread.h>

namespace rbdgrad::cli {

sigset_t block_stop_signals() noexcept {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  return set;
}

int wait_for_stop_signal(const sigset_t& set) noexcept {
  int signal = 0;
  if (sigwait(&set, &signal) != 0) return -1;
  return signal;
}

}  // namespace rbdgrad::cli
