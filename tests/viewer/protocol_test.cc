// The viewer's wire format: every message a page may send is parsed and checked; everything else is refused with a
// message that names the field, what was expected and what came.
#include "rmpmarl/viewer/protocol.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <random>

namespace rmpmarl::viewer {
namespace {

std::string fmt_json(const char* type) { return std::string(R"({"type":")") + type + "\"}"; }

CommandLimits Limits() {
  CommandLimits l;
  l.num_obstacle_ids = 20;
  return l;
}

TEST(ProtocolTest, GoodCommandsParse) {
  const CommandLimits l = Limits();
  auto parse = [&](const std::string& text) {
    const ParsedCommand p = ParseCommand(text, l);
    EXPECT_TRUE(p.command.has_value()) << text << ": " << p.error;
    return p.command.value_or(Command{});
  };
  Command c = parse(R"({"type":"set_target","p":[0.5,-0.1,0.4]})");
  EXPECT_EQ(c.kind, CommandKind::kSetTarget);
  EXPECT_EQ(c.p, Eigen::Vector3d(0.5, -0.1, 0.4));
  c = parse(R"({"type":"set_obstacle","id":19,"p":[0,0,1]})");
  EXPECT_EQ(c.id, 19);
  c = parse(R"({"type":"add_obstacle","shape":"sphere","p":[1,2,3]})");
  EXPECT_EQ(c.shape, rmp::ObstacleShape::kSphere);
  EXPECT_EQ(parse(R"({"type":"remove_obstacle","id":0})").kind, CommandKind::kRemoveObstacle);
  EXPECT_FALSE(parse(R"({"type":"reset"})").seed.has_value());
  EXPECT_EQ(parse(R"({"type":"reset","seed":7})").seed, 7u);
  EXPECT_EQ(parse(R"({"type":"speed","value":0.25})").value, 0.25);
  EXPECT_EQ(parse(R"({"type":"controller","name":"rmpflow"})").name, "rmpflow");
  EXPECT_TRUE(parse(R"({"type":"side_by_side","on":true})").on);
  for (const char* t : {"pause", "resume", "step", "release_target"}) {
    EXPECT_EQ(CommandName(parse(fmt_json(t)).kind), t);
  }
}

TEST(ProtocolTest, BadMessagesAreRefusedWithTheReason) {
  const CommandLimits l = Limits();
  struct Case {
    std::string text;
    std::string says;  // part of the refusal
  };
  const std::vector<Case> cases = {
      {"", "not JSON"},
      {"garbage", "not JSON"},
      {"[1,2,3]", "JSON object"},
      {R"({"p":[0,0,0]})", "'type'"},
      {R"({"type":5})", "'type'"},
      {R"({"type":"teleport"})", "unknown message type \"teleport\""},
      {R"({"type":"set_target"})", "set_target: field 'p' is missing"},
      {R"({"type":"set_target","p":[0,0]})", "array of 3 numbers"},
      {R"({"type":"set_target","p":"0,0,0"})", "array of 3 numbers"},
      {R"({"type":"set_target","p":[0,"x",0]})", "p[1] must be a number"},
      {R"({"type":"set_target","p":[0,0,1e999]})", "not JSON"},  // out of double's range: not a number JSON allows
      {R"({"type":"set_target","p":[0,0,1e300]})", "p[2] must be finite and within ±5 m"},
      {R"({"type":"set_target","p":[0,-5.01,0]})", "p[1] must be finite and within ±5 m"},
      {R"({"type":"set_target","p":[0,0,0],"q":1})", "unknown field 'q'"},
      {R"({"type":"set_obstacle","id":20,"p":[0,0,0]})", "'id' must be in [0, 19]"},
      {R"({"type":"set_obstacle","id":-1,"p":[0,0,0]})", "'id' must be in [0, 19]"},
      {R"({"type":"set_obstacle","id":1.5,"p":[0,0,0]})", "'id' must be an integer"},
      {R"({"type":"set_obstacle","id":18446744073709551615,"p":[0,0,0]})", "'id' must be in [0, 19]"},
      {R"({"type":"add_obstacle","shape":"cone","p":[0,0,0]})", "'shape' must be one of box, sphere"},
      {R"({"type":"speed","value":0})", "'value' must be a number in [0.1, 1]"},
      {R"({"type":"speed","value":"fast"})", "'value' must be a number"},
      {R"({"type":"controller","name":"magic"})", "'name' must be one of learned, rmpflow"},
      {R"({"type":"side_by_side","on":1})", "'on' must be true or false"},
      {R"({"type":"reset","seed":-3})", "'seed' must be in"},
      {R"({"type":"seek","frame":3})", "only a replay can seek"},
      {R"({"type":"pause","now":true})", "unknown field 'now' (it takes none)"},
      {std::string(kMaxMessageBytes + 1, ' '), "at most 16384 bytes"},
      {std::string(5000, '[') + std::string(5000, ']'), "JSON object"},
  };
  for (const Case& c : cases) {
    const ParsedCommand p = ParseCommand(c.text, l);
    EXPECT_FALSE(p.command.has_value()) << c.text.substr(0, 80);
    EXPECT_NE(p.error.find(c.says), std::string::npos) << c.text.substr(0, 80) << " → " << p.error;
    EXPECT_LT(p.error.size(), 400u) << "a refusal is one short line";
  }
}

TEST(ProtocolTest, RandomBytesAndMutatedCommandsNeverCrashAndAreCheckedByTheParser) {
  const CommandLimits l = Limits();
  std::mt19937_64 rng(11);
  const std::vector<std::string> seeds = {R"({"type":"set_target","p":[0.5,-0.1,0.4]})",
                                          R"({"type":"add_obstacle","shape":"box","p":[1,2,3]})",
                                          R"({"type":"speed","value":0.5})"};
  int accepted = 0;
  for (int n = 0; n < 20000; ++n) {
    std::string text = seeds[n % seeds.size()];
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t at = rng() % (text.size() + 1);
      switch (rng() % 3) {
        case 0: text.insert(at, 1, static_cast<char>(rng() % 256)); break;
        case 1: if (at < text.size()) text.erase(at, 1); break;
        default: if (at < text.size()) text[at] = static_cast<char>(rng() % 256); break;
      }
    }
    const ParsedCommand p = ParseCommand(text, l);
    ASSERT_NE(p.command.has_value(), !p.error.empty());
    if (p.command) {
      ++accepted;
      const Command& c = *p.command;
      ASSERT_TRUE(c.p.allFinite());
      ASSERT_LE(c.p.cwiseAbs().maxCoeff(), l.arena);
      ASSERT_GE(c.value, l.min_speed);
      ASSERT_LE(c.value, l.max_speed);
    }
  }
  EXPECT_GT(accepted, 0);  // some mutations (e.g. in a number) stay valid
}

TEST(ProtocolTest, HelloDescribesTheRobot) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  HelloInfo info;
  info.arms = {{"marl-rmp-residual", "learned"}};
  info.controllers = {"learned", "rmpflow"};
  info.controller = "learned";
  const auto hello = nlohmann::json::parse(EncodeHello(robot, info));
  EXPECT_EQ(hello["type"], "hello");
  EXPECT_EQ(hello["version"], kProtocolVersion);
  EXPECT_EQ(hello["robot"]["nq"], 7);
  EXPECT_EQ(hello["robot"]["capsules"].size(), robot.capsules.size());
  EXPECT_EQ(hello["robot"]["links"].size(), static_cast<std::size_t>(robot.model.num_links()));
  for (int i = 0; i < 7; ++i) {
    // joint i moves its link
    const int link = hello["robot"]["joint_links"][i].get<int>();
    EXPECT_EQ(robot.model.link(link).q_index, i);
  }
  EXPECT_FALSE(hello.contains("replay"));
}

}  // namespace
}  // namespace rmpmarl::viewer
