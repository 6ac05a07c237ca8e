// The viewer's simulation loop on the wall clock: real time, slow motion, pause and single steps, and a flood of
// messages that it refuses without stopping.
#include "rmpmarl/viewer/realtime.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <thread>

#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::viewer {
namespace {

using namespace std::chrono_literals;

struct Running {
  LiveSim sim{kinematics::LoadShippedRobot("panda"), nullptr, "", LiveSimOptions{.controller = "rmpflow"}};
  std::mutex mutex;
  std::vector<nlohmann::json> frames, replies;
  std::unique_ptr<Realtime> loop;
  std::thread thread;

  explicit Running(RealtimeOptions options = {}) {
    options.log_refusals = false;
    loop = std::make_unique<Realtime>(
        sim, options,
        [this](auto m) {
          std::lock_guard lock(mutex);
          frames.push_back(nlohmann::json::parse(*m));
        },
        Publish());
    thread = std::thread([this] { loop->Run(); });
  }
  ~Running() {
    loop->Stop();
    thread.join();
  }
  nlohmann::json Last() {
    std::lock_guard lock(mutex);
    return frames.empty() ? nlohmann::json() : frames.back();
  }
  void Send(const std::string& text) {
    loop->Submit(text, [this](auto m) {
      std::lock_guard lock(mutex);
      replies.push_back(nlohmann::json::parse(*m));
    });
  }
};

TEST(RealtimeTest, KeepsTheWallClockAtEverySpeedAndPausesAndSteps) {
  Running r;
  std::this_thread::sleep_for(300ms);
  const auto start = std::chrono::steady_clock::now();
  const double t0 = r.Last()["t"].get<double>();
  std::this_thread::sleep_for(1500ms);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double advanced = r.Last()["t"].get<double>() - t0;
  // one frame period (33 ms) of slack each side, and a loaded machine's scheduling
  EXPECT_NEAR(advanced, wall, 0.15) << "simulated " << advanced << " s in " << wall << " s";

  r.Send(R"({"type":"speed","value":0.25})");
  std::this_thread::sleep_for(200ms);
  const double s0 = r.Last()["t"].get<double>();
  std::this_thread::sleep_for(1200ms);
  const nlohmann::json slow = r.Last();
  EXPECT_NEAR(slow["t"].get<double>() - s0, 0.3, 0.08);
  EXPECT_EQ(slow["speed"], 0.25);

  r.Send(R"({"type":"pause"})");
  std::this_thread::sleep_for(200ms);
  const double p0 = r.Last()["t"].get<double>();
  std::this_thread::sleep_for(300ms);
  EXPECT_TRUE(r.Last()["paused"].get<bool>());
  EXPECT_EQ(r.Last()["t"].get<double>(), p0) << "paused: the simulation holds";
  for (int k = 0; k < 3; ++k) r.Send(R"({"type":"step"})");
  std::this_thread::sleep_for(200ms);
  EXPECT_NEAR(r.Last()["t"].get<double>() - p0, 3 * r.sim.control_period(), 1e-9) << "three control steps";
  r.Send(R"({"type":"resume"})");
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(r.Last()["t"].get<double>(), p0 + 0.03);
  EXPECT_EQ(r.loop->counters().refused.load(), 0);
}

TEST(RealtimeTest, TheRealTimeFactorStaysMeaningfulAcrossAReset) {
  Running r;
  std::this_thread::sleep_for(1300ms);
  r.Send(R"({"type":"reset"})");
  std::this_thread::sleep_for(1500ms);
  std::lock_guard lock(r.mutex);
  bool after_reset = false;
  for (std::size_t i = 1; i < r.frames.size(); ++i) {
    if (r.frames[i]["t"].get<double>() < r.frames[i - 1]["t"].get<double>()) after_reset = true;
    if (after_reset) {
      EXPECT_TRUE(r.frames[i]["rtf"].get<double>() >= 0.0 && r.frames[i]["rtf"].get<double>() < 1.5)
          << "frame " << i << ": rtf " << r.frames[i]["rtf"];
    }
  }
  EXPECT_TRUE(after_reset) << "the reset went back in simulated time";
}

TEST(RealtimeTest, APageThatFloodsTheQueueLeavesRoomForTheOthers) {
  LiveSim sim(kinematics::LoadShippedRobot("panda"), nullptr, "", LiveSimOptions{.controller = "rmpflow"});
  RealtimeOptions options;
  options.log_refusals = false;
  Realtime loop(sim, options, Publish(), Publish());  // not running: the queue only fills
  std::vector<std::string> to_flooder, to_other;
  for (int k = 0; k < 100; ++k) {
    loop.Submit(R"({"type":"pause"})", [&](auto m) { to_flooder.push_back(*m); }, 1);
  }
  loop.Submit(R"({"type":"pause"})", [&](auto m) { to_other.push_back(*m); }, 2);
  EXPECT_EQ(to_flooder.size(), 36u) << "the flooder's 65th and later messages";
  EXPECT_NE(to_flooder.front().find("64 of yours waiting"), std::string::npos) << to_flooder.front();
  EXPECT_TRUE(to_other.empty()) << "another page's message still fits";
  EXPECT_EQ(loop.counters().refused.load(), 36);
}

TEST(RealtimeTest, AFloodOfMessagesIsRefusedOrAppliedAndTheLoopGoesOn) {
  RealtimeOptions options;
  options.max_queued = 64;
  Running r(options);
  std::this_thread::sleep_for(200ms);
  for (int k = 0; k < 2000; ++k) r.Send(R"({"type":"add_obstacle","shape":"box","p":[0.5,0.0,0.3]})");
  for (int k = 0; k < 500; ++k) r.Send(R"({"type":"set_target","p":[NaN,0,0]})");
  std::this_thread::sleep_for(300ms);
  const double t0 = r.Last()["t"].get<double>();
  std::this_thread::sleep_for(500ms);
  const nlohmann::json f = r.Last();
  EXPECT_GT(f["t"].get<double>(), t0 + 0.3) << "the simulation went on";
  // 4 scenario cubes + 8 added ones: the room for cubes is full
  EXPECT_EQ(f["obstacles"].size(), 12u);
  const long refused = r.loop->counters().refused.load();
  EXPECT_EQ(refused + r.loop->counters().accepted.load(), 2500);
  EXPECT_EQ(f["refused"].get<long>(), refused);
  std::lock_guard lock(r.mutex);
  EXPECT_EQ(static_cast<long>(r.replies.size()), refused) << "every refusal is answered";
}

}  // namespace
}  // namespace rmpmarl::viewer
