// The bound on a backend call (scheduler.backend_timeout_ms, issue 9): a call that has run past
// its limit is given up and its request runs again elsewhere (ComputeCall). A CallAttempt is
// shared by the thread that computes and the watchdog's thread; whichever settles it first under
// its mutex decides what happens: the call returned in time (kDone), or the watchdog took the
// request away (kTimedOut: the late result is dropped, and the buffers the plugin may still write
// stay with the attempt until it returns), or found no other backend for it (kWaiting: the call
// goes on, and its result is the answer).
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "rbdgrad/plugin_api.h"
#include "rbdgrad/v1/dynamics.pb.h"
#include "request_batch.hpp"

namespace rbdgrad::server {

class ComputeCall;
class Scheduler;
struct BackendState;

struct CallAttempt {
  using Clock = std::chrono::steady_clock;
  enum class State { kRunning, kDone, kTimedOut, kWaiting };

  std::mutex mutex;
  State state = State::kRunning;  // under mutex
  ComputeCall* call = nullptr;    // alive while kRunning: the call waits for its compute
  Clock::time_point started{};
  Clock::time_point deadline{};
  const BackendState* backend = nullptr;
  const Scheduler* scheduler = nullptr;  // outlives the pools (Daemon's destructor)
  rbdgrad_batch batch{};                 // what the plugin was given: its address stays put
  // after kTimedOut: the call's buffers and response, which the plugin may still write into
  RequestBatch buffers;
  rbdgrad::v1::ComputeResponse response;

 private:
  friend class Watchdog;
  bool listed_ = false;  // in the watchdog's list (under its mutex)
  std::list<std::shared_ptr<CallAttempt>>::iterator where_;
};

class Watchdog {
 public:
  /// `expired` runs on the watchdog's thread for each attempt whose deadline passed while it was
  /// listed (it is no longer listed then).
  explicit Watchdog(std::function<void(const std::shared_ptr<CallAttempt>&)> expired);
  /// Stops the thread; attempts still listed are forgotten.
  ~Watchdog();
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

  /// Watches `attempt` until its deadline or remove(). Thread-safe.
  void add(const std::shared_ptr<CallAttempt>& attempt);
  /// Stops watching `attempt` (nothing when it is not listed). Thread-safe.
  void remove(CallAttempt& attempt);

 private:
  void loop();

  const std::function<void(const std::shared_ptr<CallAttempt>&)> expired_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::list<std::shared_ptr<CallAttempt>> attempts_;  // the calls computing now: at most those in flight
  CallAttempt::Clock::time_point next_ = CallAttempt::Clock::time_point::max();  // when the thread wakes
  bool stop_ = false;
  std::thread thread_;  // last: started once the rest exists
};

}  // namespace rbdgrad::server
