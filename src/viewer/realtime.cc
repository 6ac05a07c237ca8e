#include "rmpmarl/viewer/realtime.h"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <cmath>
#include <thread>

#include "rmpmarl/common/error.h"

namespace rmpmarl::viewer {

Realtime::Realtime(FrameSource& source, RealtimeOptions options, Publish on_frame, Publish on_hello)
    : source_(source), options_(options), on_frame_(std::move(on_frame)), on_hello_(std::move(on_hello)) {
  if (!(options_.fps > 0.0 && options_.fps <= 240.0)) {
    throw InputError(fmt::format("viewer: fps must be in (0, 240], got {:g}", options_.fps));
  }
  if (options_.max_queued < 1 || options_.max_queued_per_sender < 1 || !(options_.max_lag > 0.0)) {
    throw InputError("viewer: max_queued and max_queued_per_sender must be >= 1 and max_lag > 0");
  }
  paused_ = options_.start_paused;
  hello_ = std::make_shared<const std::string>(source_.hello());
  hello_version_ = source_.hello_version();
}

std::shared_ptr<const std::string> Realtime::hello() const {
  std::lock_guard lock(mutex_);
  return hello_;
}

void Realtime::Refuse(const std::string& why, const Reply& reply) {
  const long n = ++counters_.refused;
  if (options_.log_refusals && (n <= 100 || n % 1000 == 0)) {
    fmt::print(stderr, "rmpmarl view: refused message #{}: {}\n", n, why);
  }
  if (reply) reply(std::make_shared<const std::string>(EncodeError(why)));
}

void Realtime::Submit(std::string text, Reply reply, long sender) {
  std::size_t waiting = 0;
  {
    std::lock_guard lock(mutex_);
    std::size_t& mine = queued_by_sender_[sender];
    if (queue_.size() < options_.max_queued && mine < options_.max_queued_per_sender) {
      ++mine;
      queue_.push_back({std::move(text), std::move(reply)});
      return;
    }
    waiting = mine;
  }
  Refuse(fmt::format("message queue full ({} of yours waiting, at most {}; {} in all): the simulation applies "
                     "messages between control steps",
                     waiting, options_.max_queued_per_sender, options_.max_queued),
         reply);
}

void Realtime::Rebase() {
  wall0_ = Clock::now();
  sim0_ = source_.time();
}

void Realtime::RestartWindow() {
  window_start_ = Clock::now();
  window_sim_start_ = source_.time();
  window_busy_ = 0.0;
}

void Realtime::PublishHelloIfChanged() {
  if (source_.hello_version() == hello_version_) return;
  auto hello = std::make_shared<const std::string>(source_.hello());
  {
    std::lock_guard lock(mutex_);
    hello_ = hello;
  }
  hello_version_ = source_.hello_version();
  if (on_hello_) on_hello_(hello);
}

void Realtime::Drain() {
  std::deque<Pending> pending;
  {
    std::lock_guard lock(mutex_);
    pending.swap(queue_);
    queued_by_sender_.clear();
  }
  for (Pending& m : pending) {
    const ParsedCommand parsed = ParseCommand(m.text, source_.limits());
    if (!parsed.command) {
      Refuse(parsed.error, m.reply);
      continue;
    }
    const Command& c = *parsed.command;
    std::string refusal;
    switch (c.kind) {
      case CommandKind::kPause:
        paused_ = true;
        break;
      case CommandKind::kResume:
        paused_ = false;
        break;
      case CommandKind::kStep:
        if (!paused_) {
          refusal = "step: pause first (a running simulation steps by itself)";
        } else {
          ++steps_requested_;
        }
        break;
      case CommandKind::kSpeed: {
        // continuous in simulated time: the anchor moves to now at the old speed
        const auto now = Clock::now();
        sim0_ += speed_ * std::chrono::duration<double>(now - wall0_).count();
        wall0_ = now;
        speed_ = c.value;
        RestartWindow();
        break;
      }
      default:
        try {
          refusal = source_.Apply(c);
        } catch (const InputError& e) {
          refusal = fmt::format("{}: {}", CommandName(c.kind), e.what());
        } catch (const std::exception& e) {
          // not the page's fault, but the simulation goes on without this command
          refusal = fmt::format("{}: failed: {}", CommandName(c.kind), e.what());
        }
        break;
    }
    if (!refusal.empty()) {
      Refuse(refusal, m.reply);
      continue;
    }
    ++counters_.accepted;
    // simulated time jumped (a new episode, a seek) or the clock restarts (resume): the real-time factor is measured
    // afresh
    if (c.kind == CommandKind::kReset || c.kind == CommandKind::kSeek || c.kind == CommandKind::kResume) {
      Rebase();
      RestartWindow();
    }
  }
}

void Realtime::Run() {
  using std::chrono::duration;
  const duration<double> frame_period(1.0 / options_.fps);
  auto next_frame = Clock::now();
  RestartWindow();
  double rtf = 1.0, load = 0.0;
  std::string frame;
  PublishHelloIfChanged();
  if (on_hello_) on_hello_(hello());
  Rebase();
  while (!stop_) {
    const auto busy_start = Clock::now();
    Drain();
    PublishHelloIfChanged();
    const double before = source_.time();
    if (paused_) {
      for (; steps_requested_ > 0; --steps_requested_) source_.StepOnce();
      Rebase();
    } else {
      steps_requested_ = 0;
      const double wall = duration<double>(Clock::now() - wall0_).count();
      double target = sim0_ + speed_ * wall;
      // behind by more than max_lag (and able to advance at all: a replay at its end cannot) gives up catching up
      if (target - source_.time() > options_.max_lag && std::isfinite(source_.next_time())) {
        ++counters_.overruns;
        Rebase();
        target = source_.time() + 0.02;
      }
      source_.AdvanceTo(target);
    }
    const auto now = Clock::now();
    window_busy_ += duration<double>(now - busy_start).count();
    if (source_.time() > before) ++counters_.advances;
    // statistics over the last second of wall time
    const double span = duration<double>(now - window_start_).count();
    if (span >= 1.0) {
      if (!paused_) rtf = (source_.time() - window_sim_start_) / (span * speed_);
      load = window_busy_ / span;
      RestartWindow();
    }
    if (now >= next_frame) {
      FrameStats stats;
      stats.seq = counters_.frames++;
      stats.paused = paused_;
      stats.speed = speed_;
      stats.rtf = paused_ ? 0.0 : rtf;
      stats.load = load;
      stats.refused = counters_.refused.load();
      source_.Frame(stats, &frame);
      if (on_frame_) on_frame_(std::make_shared<const std::string>(frame));
      next_frame += std::chrono::duration_cast<Clock::duration>(frame_period);
      if (next_frame < now) next_frame = now + std::chrono::duration_cast<Clock::duration>(frame_period);
    }
    // sleep to the next control step or frame, whichever comes first (at most 5 ms, so messages are applied soon)
    const auto after = Clock::now();
    auto wake = std::min(next_frame, after + std::chrono::milliseconds(5));
    if (const double next_sim = source_.next_time(); !paused_ && std::isfinite(next_sim)) {
      // the wall time at which the source can take its next step
      const auto due = wall0_ + std::chrono::duration_cast<Clock::duration>(
                                    duration<double>(std::max(0.0, next_sim - sim0_) / speed_));
      wake = std::min(wake, due);
    }
    if (wake > after) std::this_thread::sleep_until(wake);
  }
}

}  // namespace rmpmarl::viewer
