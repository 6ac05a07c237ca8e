#pragma once
/// Replay files (docs/viewer.md, "Replay"): a hello and the frames of an episode, as the live viewer sends them.
/// `Recorder` writes one (`rmpmarl demo --record`), `ReplaySource` plays one back (`rmpmarl view --replay`).
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/viewer/live_sim.h"

namespace rmpmarl::viewer {

/// the largest replay file ReplaySource reads [bytes].
inline constexpr std::size_t kMaxReplayBytes = std::size_t{1} << 30;

/// the frame of a scenario's episode (`demo`): its obstacles (ids = scenario indices) and target, the arms given.
/// Clearances are computed here (Clearance); an arm's `contacts` may be null.
std::string ScenarioFrame(long seq, double time, const sim::Scenario& scenario, std::vector<ArmView> arms);

/// one frame with the arms of `a` followed by those of `b` (two runs of the same episode shown side by side; the
/// obstacles and target are a's). Throws InputError when either is not a frame.
std::string MergeFrameArms(const std::string& a, const std::string& b);

/// Collects the frames of an episode and writes a replay file.
class Recorder {
 public:
  /// `hello` is the hello message of the episode (its mode is replaced by "replay" on writing).
  explicit Recorder(std::string hello);
  /// appends a frame message (EncodeFrame's text).
  void AddFrame(std::string frame);
  /// writes the file (replacing it). Throws InputError naming the path when it cannot be written.
  void Write(const std::string& path) const;
  std::size_t frames() const { return frames_.size(); }

 private:
  std::string hello_;
  std::vector<std::string> frames_;
};

/// A recorded episode played back: the frames at their recorded times; pause, step (one frame), seek, speed.
class ReplaySource final : public FrameSource {
 public:
  /// reads a replay file. Throws InputError naming the file for anything it cannot play (missing, too large, not
  /// JSON, wrong format or version, no frames, frames without increasing times).
  explicit ReplaySource(const std::string& path);
  ~ReplaySource() override;

  const CommandLimits& limits() const override { return limits_; }
  std::string Apply(const Command& command) override;
  void AdvanceTo(double t) override;
  void StepOnce() override;
  double time() const override;
  double next_time() const override;
  const std::string& hello() const override { return hello_; }
  long hello_version() const override { return 1; }
  void Frame(const FrameStats& stats, std::string* out) override;

  long num_frames() const { return static_cast<long>(times_.size()); }
  long index() const { return index_; }

 private:
  struct Frames;
  CommandLimits limits_;
  std::string hello_;
  std::vector<double> times_;
  std::unique_ptr<Frames> frames_;
  long index_ = 0;
};

}  // namespace rmpmarl::viewer
