// Replay files: `rmpmarl demo --record` writes one, ReplaySource plays it back frame by frame; files it cannot
// play are refused with the reason.
#include "rmpmarl/viewer/recording.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "rmpmarl/common/error.h"

namespace rmpmarl::viewer {
namespace {

using nlohmann::json;

std::filesystem::path Temp(const std::string& name) {
  return std::filesystem::temp_directory_path() / fmt::format("rmpmarl-replay-{}-{}", ::getpid(), name);
}

TEST(RecordingTest, DemoRecordsBothRunsAndTheReplayPlaysThemFrameByFrame) {
  const auto path = Temp("demo.json");
  const std::string cmd = fmt::format("{} demo --duration 2 --fps 20 --record {} > /dev/null", RMPMARL_CLI_PATH,
                                      path.string());
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  ReplaySource replay(path.string());
  ASSERT_EQ(replay.num_frames(), 41);  // t = 0 … 2 s at 20 frames per second, both ends
  const json hello = json::parse(replay.hello());
  EXPECT_EQ(hello["mode"], "replay");
  EXPECT_EQ(hello["arms"].size(), 2u);
  EXPECT_EQ(hello["arms"][0]["controller"], "learned");
  EXPECT_EQ(hello["replay"]["frames"], 41);
  std::string out;
  replay.Frame({}, &out);
  json f = json::parse(out);
  EXPECT_EQ(f["index"], 0);
  EXPECT_EQ(f["arms"].size(), 2u);
  EXPECT_EQ(f["arms"][0]["joints"].size(), 7u) << "the learned arm's agents are recorded";
  EXPECT_TRUE(f["arms"][1]["joints"].is_null());
  // real time: at t the last frame at or before t
  replay.AdvanceTo(0.51);
  EXPECT_EQ(replay.index(), 10);
  EXPECT_NEAR(replay.time(), 0.5, 1e-9);
  replay.StepOnce();
  EXPECT_EQ(replay.index(), 11);
  Command seek;
  seek.kind = CommandKind::kSeek;
  seek.frame = 40;
  EXPECT_EQ(replay.Apply(seek), "");
  replay.StepOnce();
  EXPECT_EQ(replay.index(), 40) << "the last frame stays";
  replay.Frame({}, &out);
  EXPECT_TRUE(json::parse(out)["paused"].get<bool>());
  Command steer;
  steer.kind = CommandKind::kSetTarget;
  EXPECT_NE(replay.Apply(steer).find("cannot be steered"), std::string::npos);
  // seeking is checked against the replay's length
  EXPECT_FALSE(ParseCommand(R"({"type":"seek","frame":41})", replay.limits()).command.has_value());
  std::filesystem::remove(path);
}

TEST(RecordingTest, FilesThatCannotBePlayedAreRefusedWithTheReason) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"not json", "not a JSON object"},
      {R"({"format":"mp4"})", "\"format\" is not \"rmpmarl-replay\""},
      {R"({"format":"rmpmarl-replay","version":2})", "version must be 1"},
      {R"({"format":"rmpmarl-replay","version":1,"hello":{}})", "no hello"},
      {R"({"format":"rmpmarl-replay","version":1,"hello":{"type":"hello","robot":{},"arms":[{}]},"frames":[]})",
       "no frames"},
      {R"({"format":"rmpmarl-replay","version":1,"hello":{"type":"hello","robot":{},"arms":[{}]},
          "frames":[{"type":"frame","t":1,"arms":[{}]},{"type":"frame","t":0.5,"arms":[{}]}]})",
       "frame 1: time 0.5 is not after the last"},
      {R"({"format":"rmpmarl-replay","version":1,"hello":{"type":"hello","robot":{},"arms":[{}]},
          "frames":[{"type":"frame","t":1,"arms":[{},{}]}]})",
       "frame 0 is not a frame with a time and 1 arm(s)"},
  };
  const auto path = Temp("bad.json");
  for (const auto& [text, says] : cases) {
    std::ofstream(path) << text;
    try {
      ReplaySource replay(path.string());
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << "names the file";
    }
  }
  std::filesystem::remove(path);
  EXPECT_THROW(ReplaySource("/nonexistent/replay.json"), InputError);
}

}  // namespace
}  // namespace rmpmarl::viewer
