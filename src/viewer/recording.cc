#include "rmpmarl/viewer/recording.h"

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "rmpmarl/common/error.h"

namespace rmpmarl::viewer {

using nlohmann::json;

std::string ScenarioFrame(long seq, double time, const sim::Scenario& scenario, std::vector<ArmView> arms) {
  std::vector<ObstacleView> obstacles;
  for (int j = 0; j < scenario.num_obstacles(); ++j) {
    const rmp::Obstacle o = scenario.ObstacleAsRmp(j);
    if (rmp::Centre(o).z() < sim::ParkedPose().translation().z() + 1.0) continue;  // parked, out of the scene
    obstacles.push_back({j, o, false});
  }
  for (ArmView& arm : arms) {
    arm.p_WE = arm.world->EndEffectorPosition();
    arm.clearance = Clearance(*arm.world, obstacles);
  }
  FrameView f;
  f.seq = seq;
  f.time = time;
  f.p_WT = scenario.target().p_WT;
  f.obstacles = obstacles;
  f.arms = arms;
  std::string out;
  EncodeFrame(f, &out);
  return out;
}

std::string MergeFrameArms(const std::string& a, const std::string& b) {
  json fa = json::parse(a, nullptr, false), fb = json::parse(b, nullptr, false);
  if (fa.is_discarded() || fb.is_discarded() || !fa.contains("arms") || !fb.contains("arms")) {
    throw InputError("MergeFrameArms: both must be frames");
  }
  for (auto& arm : fb["arms"]) fa["arms"].push_back(std::move(arm));
  return fa.dump();
}

Recorder::Recorder(std::string hello) : hello_(std::move(hello)) {}

void Recorder::AddFrame(std::string frame) { frames_.push_back(std::move(frame)); }

void Recorder::Write(const std::string& path) const {
  json hello = json::parse(hello_);
  hello["mode"] = "replay";
  const std::filesystem::path p(path);
  const std::filesystem::path tmp = p.string() + ".part";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(fmt::format("--record: cannot write '{}'", path));
    out << R"({"format":"rmpmarl-replay","version":1,"hello":)" << hello.dump() << R"(,"frames":[)";
    for (std::size_t i = 0; i < frames_.size(); ++i) {
      if (i > 0) out << ",\n";
      out << frames_[i];
    }
    out << "]}\n";
    if (!out) throw InputError(fmt::format("--record: writing '{}' failed", path));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, p, ec);
  if (ec) throw InputError(fmt::format("--record: cannot write '{}': {}", path, ec.message()));
}

struct ReplaySource::Frames {
  std::vector<json> frames;
};

ReplaySource::ReplaySource(const std::string& path) : frames_(std::make_unique<Frames>()) {
  auto fail = [&](const std::string& why) { return InputError(fmt::format("--replay '{}': {}", path, why)); };
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw fail("cannot read it (" + ec.message() + ")");
  if (size > kMaxReplayBytes) throw fail(fmt::format("{} bytes, more than the {} a replay may have", size, kMaxReplayBytes));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw fail("cannot open it");
  const json file = json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (file.is_discarded() || !file.is_object()) throw fail("not a JSON object (expected a replay file)");
  if (file.value("format", std::string()) != "rmpmarl-replay") {
    throw fail("its \"format\" is not \"rmpmarl-replay\" (record one with `rmpmarl demo --record FILE`)");
  }
  if (!file.contains("version") || !file["version"].is_number_integer() || file["version"].get<int>() != 1) {
    throw fail("version must be 1");
  }
  if (!file.contains("hello") || !file["hello"].is_object() || file["hello"].value("type", "") != "hello" ||
      !file["hello"].contains("robot") || !file["hello"].contains("arms")) {
    throw fail("it has no hello with a robot and arms");
  }
  if (!file.contains("frames") || !file["frames"].is_array() || file["frames"].empty()) throw fail("it has no frames");
  const json& frames = file["frames"];
  const std::size_t num_arms = file["hello"]["arms"].size();
  double last = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const json& f = frames[i];
    if (!f.is_object() || f.value("type", "") != "frame" || !f.contains("t") || !f["t"].is_number() ||
        !f.contains("arms") || !f["arms"].is_array() || f["arms"].size() != num_arms) {
      throw fail(fmt::format("frame {} is not a frame with a time and {} arm(s)", i, num_arms));
    }
    const double t = f["t"].get<double>();
    if (!std::isfinite(t) || t < last) throw fail(fmt::format("frame {}: time {} is not after the last ({})", i, t, last));
    last = t;
    times_.push_back(t);
    frames_->frames.push_back(f);
  }
  json hello = file["hello"];
  hello["mode"] = "replay";
  hello["controllers"] = json::array();
  hello["replay"] = {{"frames", times_.size()}, {"duration", times_.back() - times_.front()}};
  hello_ = hello.dump();
  limits_.controllers.clear();
  limits_.num_frames = static_cast<long>(times_.size());
}

ReplaySource::~ReplaySource() = default;

std::string ReplaySource::Apply(const Command& command) {
  if (command.kind == CommandKind::kSeek) {
    index_ = std::clamp<long>(command.frame, 0, num_frames() - 1);
    return {};
  }
  if (command.kind == CommandKind::kReset) {
    index_ = 0;
    return {};
  }
  return fmt::format("{}: a replay cannot be steered (pause, step, seek, speed and reset only)",
                     CommandName(command.kind));
}

void ReplaySource::AdvanceTo(double t) {
  while (index_ + 1 < num_frames() && times_[index_ + 1] <= t + 1e-9) ++index_;
}

void ReplaySource::StepOnce() {
  if (index_ + 1 < num_frames()) ++index_;
}

double ReplaySource::time() const { return times_[index_]; }

double ReplaySource::next_time() const {
  return index_ + 1 < num_frames() ? times_[index_ + 1] - 1e-9 : std::numeric_limits<double>::infinity();
}

void ReplaySource::Frame(const FrameStats& stats, std::string* out) {
  json f = frames_->frames[index_];
  f["seq"] = stats.seq;
  f["paused"] = stats.paused || index_ + 1 == num_frames();
  f["speed"] = stats.speed;
  f["rtf"] = stats.rtf;
  f["load"] = stats.load;
  f["refused"] = stats.refused;
  f["index"] = index_;
  *out = f.dump();
}

}  // namespace rmpmarl::viewer
