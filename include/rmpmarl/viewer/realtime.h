#pragma once
/// The viewer's simulation loop: runs a FrameSource in real time (times the speed) on its own thread, applies the
/// pages' commands between control steps, and publishes a frame about `fps` times per second. Pages hand in raw
/// messages from any thread (Submit); parsing, checking and applying happen on the loop's thread, so the source is
/// only ever touched there. A refused message is counted, logged and answered; it never stops the loop.
#include <atomic>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "rmpmarl/viewer/live_sim.h"

namespace rmpmarl::viewer {

/// Options of the loop.
struct RealtimeOptions {
  double fps = 30.0;           ///< frames published per wall second, in (0, 240]
  std::size_t max_queued = 256; ///< messages waiting at most; more are refused
  /// messages one sender may have waiting (a page that floods the queue leaves room for the others)
  std::size_t max_queued_per_sender = 64;
  /// when the simulation falls this far behind the wall clock [s] it gives up catching up (counted as an overrun)
  double max_lag = 0.25;
  bool start_paused = false;
  bool log_refusals = true;    ///< one line on stderr per refused message (the first 100, then every 1000th)
};

/// Where published messages go (the server's broadcast); called on the loop's thread.
using Publish = std::function<void(std::shared_ptr<const std::string> message)>;
/// Where a refusal goes (the sender's socket); called on the loop's thread or the caller's.
using Reply = std::function<void(std::shared_ptr<const std::string> message)>;

/// Counters of the loop (read from any thread).
struct RealtimeCounters {
  std::atomic<long> frames{0};
  std::atomic<long> advances{0};  ///< loop turns in which simulated time advanced
  std::atomic<long> accepted{0};
  std::atomic<long> refused{0};
  std::atomic<long> overruns{0};
};

class Realtime {
 public:
  /// `on_frame` gets every frame, `on_hello` every hello (the first at Run's start). Throws InputError for bad options.
  Realtime(FrameSource& source, RealtimeOptions options, Publish on_frame, Publish on_hello);

  /// queues a page's message (thread-safe; refuses it at once when the queue, or the sender's share of it, is full).
  /// `sender` identifies the page (any number; messages of one sender are applied in order).
  void Submit(std::string text, Reply reply, long sender = 0);
  /// runs until Stop (blocking).
  void Run();
  /// asks Run to return (thread-safe).
  void Stop() { stop_ = true; }

  const RealtimeCounters& counters() const { return counters_; }
  /// counts, logs and answers a refused message (thread-safe; `reply` may be empty).
  void Refuse(const std::string& why, const Reply& reply);
  /// the hello last published (thread-safe), for a page that connects.
  std::shared_ptr<const std::string> hello() const;

 private:
  struct Pending {
    std::string text;
    Reply reply;
  };
  void Drain();
  void PublishHelloIfChanged();
  void Rebase();
  void RestartWindow();

  using Clock = std::chrono::steady_clock;
  FrameSource& source_;
  RealtimeOptions options_;
  Publish on_frame_, on_hello_;
  RealtimeCounters counters_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::deque<Pending> queue_;
  std::unordered_map<long, std::size_t> queued_by_sender_;
  std::shared_ptr<const std::string> hello_;
  long hello_version_ = -1;
  bool paused_ = false;
  double speed_ = 1.0;
  int steps_requested_ = 0;
  // the wall-clock anchor: simulated time sim0_ at wall time wall0_
  Clock::time_point wall0_;
  double sim0_ = 0.0;
  // the current measuring window of the real-time factor and load
  Clock::time_point window_start_;
  double window_sim_start_ = 0.0, window_busy_ = 0.0;
};

}  // namespace rmpmarl::viewer
