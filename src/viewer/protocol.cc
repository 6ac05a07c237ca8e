#include "rmpmarl/viewer/protocol.h"

#include <fmt/format.h>
#include <mujoco/mjdata.h>
#include <mujoco/mjmodel.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/sim/world.h"
#include "rmpmarl/control/agent_interface.h"

namespace rmpmarl::viewer {
namespace {

using nlohmann::json;

struct Kind {
  std::string_view name;
  CommandKind kind;
};
constexpr Kind kKinds[] = {
    {"set_target", CommandKind::kSetTarget},       {"release_target", CommandKind::kReleaseTarget},
    {"set_obstacle", CommandKind::kSetObstacle},   {"add_obstacle", CommandKind::kAddObstacle},
    {"remove_obstacle", CommandKind::kRemoveObstacle}, {"pause", CommandKind::kPause},
    {"resume", CommandKind::kResume},              {"step", CommandKind::kStep},
    {"reset", CommandKind::kReset},                {"speed", CommandKind::kSpeed},
    {"controller", CommandKind::kController},      {"side_by_side", CommandKind::kSideBySide},
    {"seek", CommandKind::kSeek},
};

// a short, printable excerpt of a received value for an error message
std::string Excerpt(const json& value) {
  std::string s = value.dump(-1, ' ', true, json::error_handler_t::replace);
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return s;
}

std::string TypeName(const json& value) {
  return std::string(value.type_name());
}

// The fields of one message, read with messages that name the command and field.
class Reader {
 public:
  Reader(const json& message, std::string_view command) : message_(message), command_(command) {}

  const std::string& error() const { return error_; }
  bool ok() const { return error_.empty(); }

  const json* Field(std::string_view name, bool required = true) {
    if (!ok()) return nullptr;
    const auto it = message_.find(name);
    if (it == message_.end()) {
      if (required) Fail(fmt::format("{}: field '{}' is missing", command_, name));
      return nullptr;
    }
    return &*it;
  }

  Eigen::Vector3d Position(std::string_view name, double arena) {
    const json* v = Field(name);
    if (v == nullptr) return Eigen::Vector3d::Zero();
    if (!v->is_array() || v->size() != 3) {
      Fail(fmt::format("{}: '{}' must be an array of 3 numbers [m], got {}", command_, name, Excerpt(*v)));
      return Eigen::Vector3d::Zero();
    }
    Eigen::Vector3d p;
    for (int i = 0; i < 3; ++i) {
      const json& c = (*v)[i];
      if (!c.is_number()) {
        Fail(fmt::format("{}: {}[{}] must be a number [m], got {} ({})", command_, name, i, Excerpt(c), TypeName(c)));
        return Eigen::Vector3d::Zero();
      }
      p[i] = c.get<double>();
      if (!std::isfinite(p[i]) || std::abs(p[i]) > arena) {
        Fail(fmt::format("{}: {}[{}] must be finite and within ±{:g} m of the base, got {}", command_, name, i, arena,
                         Excerpt(c)));
        return Eigen::Vector3d::Zero();
      }
    }
    return p;
  }

  long Integer(std::string_view name, long lo, long hi) {
    const json* v = Field(name);
    if (v == nullptr) return lo;
    if (!v->is_number_integer()) {
      Fail(fmt::format("{}: '{}' must be an integer, got {} ({})", command_, name, Excerpt(*v), TypeName(*v)));
      return lo;
    }
    if (v->is_number_unsigned() && v->get<std::uint64_t>() > static_cast<std::uint64_t>(hi)) {
      Fail(fmt::format("{}: '{}' must be in [{}, {}], got {}", command_, name, lo, hi, Excerpt(*v)));
      return lo;
    }
    const long x = v->get<long>();
    if (x < lo || x > hi) {
      Fail(fmt::format("{}: '{}' must be in [{}, {}], got {}", command_, name, lo, hi, x));
      return lo;
    }
    return x;
  }

  double Number(std::string_view name, double lo, double hi) {
    const json* v = Field(name);
    if (v == nullptr) return lo;
    const double x = v->is_number() ? v->get<double>() : std::numeric_limits<double>::quiet_NaN();
    if (!std::isfinite(x) || x < lo || x > hi) {
      Fail(fmt::format("{}: '{}' must be a number in [{:g}, {:g}], got {}", command_, name, lo, hi, Excerpt(*v)));
      return lo;
    }
    return x;
  }

  std::string OneOf(std::string_view name, const std::vector<std::string>& allowed) {
    const json* v = Field(name);
    if (v == nullptr) return {};
    if (v->is_string()) {
      const std::string s = v->get<std::string>();
      if (std::find(allowed.begin(), allowed.end(), s) != allowed.end()) return s;
    }
    Fail(fmt::format("{}: '{}' must be one of {}, got {}", command_, name, fmt::join(allowed, ", "), Excerpt(*v)));
    return {};
  }

  bool Boolean(std::string_view name) {
    const json* v = Field(name);
    if (v == nullptr) return false;
    if (!v->is_boolean()) {
      Fail(fmt::format("{}: '{}' must be true or false, got {}", command_, name, Excerpt(*v)));
      return false;
    }
    return v->get<bool>();
  }

  // refuses fields this command does not know (a misspelt field is a mistake worth reporting)
  void NoOtherFields(std::initializer_list<std::string_view> known) {
    if (!ok()) return;
    for (auto it = message_.begin(); it != message_.end(); ++it) {
      if (it.key() == "type") continue;
      if (std::find(known.begin(), known.end(), it.key()) == known.end()) {
        std::string key = it.key().size() > 32 ? it.key().substr(0, 29) + "..." : it.key();
        Fail(fmt::format("{}: unknown field '{}'{}", command_, Excerpt(json(key)).substr(1, key.size()),
                         known.size() == 0 ? std::string(" (it takes none)")
                                           : fmt::format(" (it takes {})", fmt::join(known, ", "))));
        return;
      }
    }
  }

 private:
  void Fail(std::string why) {
    if (error_.empty()) error_ = std::move(why);
  }
  const json& message_;
  std::string_view command_;
  std::string error_;
};

}  // namespace

std::string_view CommandName(CommandKind kind) {
  for (const Kind& k : kKinds) {
    if (k.kind == kind) return k.name;
  }
  return "?";
}

ParsedCommand ParseCommand(std::string_view text, const CommandLimits& limits) {
  ParsedCommand out;
  if (text.size() > kMaxMessageBytes) {
    out.error = fmt::format("message of {} bytes refused: at most {} bytes", text.size(), kMaxMessageBytes);
    return out;
  }
  const json message = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (message.is_discarded()) {
    out.error = fmt::format("message is not JSON ({} bytes)", text.size());
    return out;
  }
  if (!message.is_object()) {
    out.error = fmt::format("message must be a JSON object with a 'type', got {}", TypeName(message));
    return out;
  }
  const auto type = message.find("type");
  if (type == message.end() || !type->is_string()) {
    out.error = "message must have a string field 'type'";
    return out;
  }
  const std::string name = type->get<std::string>();
  const Kind* kind = std::find_if(std::begin(kKinds), std::end(kKinds), [&](const Kind& k) { return k.name == name; });
  if (kind == std::end(kKinds)) {
    std::vector<std::string_view> names;
    for (const Kind& k : kKinds) names.push_back(k.name);
    out.error = fmt::format("unknown message type {} (known: {})", Excerpt(*type), fmt::join(names, ", "));
    return out;
  }
  Command c;
  c.kind = kind->kind;
  Reader r(message, kind->name);
  const long max_id = std::max(0, limits.num_obstacle_ids - 1);
  switch (c.kind) {
    case CommandKind::kSetTarget:
      c.p = r.Position("p", limits.arena);
      r.NoOtherFields({"p"});
      break;
    case CommandKind::kSetObstacle:
      c.id = static_cast<int>(r.Integer("id", 0, max_id));
      c.p = r.Position("p", limits.arena);
      r.NoOtherFields({"id", "p"});
      break;
    case CommandKind::kAddObstacle: {
      const std::string shape = r.OneOf("shape", {"box", "sphere"});
      c.shape = shape == "sphere" ? rmp::ObstacleShape::kSphere : rmp::ObstacleShape::kBox;
      c.p = r.Position("p", limits.arena);
      r.NoOtherFields({"shape", "p"});
      break;
    }
    case CommandKind::kRemoveObstacle:
      c.id = static_cast<int>(r.Integer("id", 0, max_id));
      r.NoOtherFields({"id"});
      break;
    case CommandKind::kReset:
      if (r.Field("seed", /*required=*/false) != nullptr) {
        c.seed = static_cast<std::uint64_t>(r.Integer("seed", 0, (1L << 53)));
      }
      r.NoOtherFields({"seed"});
      break;
    case CommandKind::kSpeed:
      c.value = r.Number("value", limits.min_speed, limits.max_speed);
      r.NoOtherFields({"value"});
      break;
    case CommandKind::kController:
      c.name = r.OneOf("name", limits.controllers);
      r.NoOtherFields({"name"});
      break;
    case CommandKind::kSideBySide:
      c.on = r.Boolean("on");
      r.NoOtherFields({"on"});
      break;
    case CommandKind::kSeek:
      if (limits.num_frames <= 0) {
        out.error = "seek: only a replay can seek";
        return out;
      }
      c.frame = r.Integer("frame", 0, limits.num_frames - 1);
      r.NoOtherFields({"frame"});
      break;
    case CommandKind::kReleaseTarget:
    case CommandKind::kPause:
    case CommandKind::kResume:
    case CommandKind::kStep:
      r.NoOtherFields({});
      break;
  }
  if (!r.ok()) {
    out.error = r.error();
    return out;
  }
  out.command = std::move(c);
  return out;
}

// ---- server → page

namespace {

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

template <typename Out>
void AppendVec(Out& out, const Eigen::Vector3d& v) {
  fmt::format_to(std::back_inserter(out), "[{:.4f},{:.4f},{:.4f}]", v.x(), v.y(), v.z());
}

template <typename Out>
void AppendNumber(Out& out, double x, const char* fmt_spec = "{:.4f}") {
  if (std::isfinite(x)) {
    fmt::format_to(std::back_inserter(out), fmt::runtime(fmt_spec), x);
  } else {
    fmt::format_to(std::back_inserter(out), "null");
  }
}

}  // namespace

std::string EncodeHello(const kinematics::Robot& robot, const HelloInfo& info) {
  const kinematics::Model& model = robot.model;
  json joints = json::array(), links = json::array(), joint_links = json::array(), capsules = json::array();
  for (int i = 0; i < model.nq(); ++i) {
    joints.push_back(model.dof_name(i));
    joint_links.push_back(model.dof_link(i));
  }
  for (int k = 0; k < model.num_links(); ++k) links.push_back(model.link(k).name);
  for (const kinematics::LinkCapsule& c : robot.capsules) {
    capsules.push_back({{"link", c.link}, {"a", Vec(c.p_LA)}, {"b", Vec(c.p_LB)}, {"radius", c.radius}});
  }
  json arms = json::array();
  for (const ArmLabel& a : info.arms) arms.push_back({{"label", a.label}, {"controller", a.controller}});
  json options = json::array({"target", "collision", "target-then-collision"});
  json hello = {
      {"type", "hello"},
      {"version", kProtocolVersion},
      {"mode", info.mode},
      {"robot",
       {{"name", robot.name},
        {"nq", model.nq()},
        {"joints", joints},
        {"links", links},
        {"capsules", capsules},
        {"joint_links", joint_links},
        {"ee_link", robot.end_effector.link}}},
      {"arms", arms},
      {"controllers", info.controllers},
      {"controller", info.controller},
      {"side_by_side", info.side_by_side},
      {"options", options},
      {"parameters", json::array({"target s_a", "target s_m", "collision s_a", "collision s_m"})},
      {"workspace", {{"min", Vec(info.workspace_min)}, {"max", Vec(info.workspace_max)}}},
      {"limits",
       {{"max_obstacles", info.max_obstacles},
        {"arena", info.arena},
        {"speeds", json::array({info.min_speed, info.max_speed})}}},
      {"control_rate", info.control_rate},
      {"scenario", info.scenario},
      {"seed", info.seed},
  };
  json visuals = json::array();
  for (const VisualShape& v : info.visuals) {
    const kinematics::LinkShape& g = v.shape;
    const Eigen::Quaterniond q(g.X_LG.linear());
    json shape = {{"link", g.link}, {"kind", std::string(kinematics::ShapeKindName(g.kind))}};
    // meshes are sent in the link frame already; the primitives with their pose
    shape["X"] = {g.X_LG.translation().x(), g.X_LG.translation().y(), g.X_LG.translation().z(), q.w(), q.x(), q.y(),
                  q.z()};
    switch (g.kind) {
      case kinematics::ShapeKind::kSphere: shape["radius"] = g.radius; break;
      case kinematics::ShapeKind::kCylinder: shape["radius"] = g.radius; shape["length"] = g.length; break;
      case kinematics::ShapeKind::kBox: shape["size"] = Vec(g.size); break;
      case kinematics::ShapeKind::kMesh: shape["url"] = v.mesh_url; shape["X"] = {0, 0, 0, 1, 0, 0, 0}; break;
    }
    visuals.push_back(std::move(shape));
  }
  hello["robot"]["visuals"] = std::move(visuals);
  if (info.mode == "replay") {
    hello["replay"] = {{"frames", info.replay_frames}, {"duration", info.replay_duration}};
  }
  return hello.dump();
}

void EncodeFrame(const FrameView& frame, std::string* out_string) {
  std::string& out = *out_string;
  out.clear();
  auto o = std::back_inserter(out);
  fmt::format_to(o, R"({{"type":"frame","seq":{},"t":{:.4f},"paused":{},"speed":{:g},"rtf":{:.3f},"load":{:.3f},)"
                    R"("refused":{},"target":{{"p":)",
                 frame.seq, frame.time, frame.paused, frame.speed, frame.rtf, frame.load, frame.refused);
  AppendVec(out, frame.p_WT);
  fmt::format_to(o, R"(,"held":{}}},"obstacles":[)", frame.target_held);
  bool first = true;
  for (const ObstacleView& ov : frame.obstacles) {
    if (!first) out += ',';
    first = false;
    const rmp::Obstacle& ob = ov.obstacle;
    const bool sphere = ob.shape == rmp::ObstacleShape::kSphere;
    const bool cylinder = ob.shape == rmp::ObstacleShape::kCylinder;
    fmt::format_to(o, R"({{"id":{},"shape":"{}","size":)", ov.id, sphere ? "sphere" : cylinder ? "cylinder" : "box");
    if (sphere) {
      fmt::format_to(o, "[{:.4f}]", ob.sphere.radius);
    } else if (cylinder) {
      fmt::format_to(o, "[{:.4f},{:.4f}]", ob.cylinder.radius, ob.cylinder.half_length);
    } else {
      AppendVec(out, ob.box.half_size);
    }
    out += R"(,"p":)";
    AppendVec(out, rmp::Centre(ob));
    const Eigen::Quaterniond quat = sphere     ? Eigen::Quaterniond::Identity()
                                    : cylinder ? Eigen::Quaterniond(ob.cylinder.X_WC.linear()).normalized()
                                               : Eigen::Quaterniond(ob.box.X_WB.linear()).normalized();
    fmt::format_to(o, R"(,"q":[{:.5f},{:.5f},{:.5f},{:.5f}],"v":)", quat.w(), quat.x(), quat.y(), quat.z());
    AppendVec(out, ob.v_WO);
    fmt::format_to(o, R"(,"held":{}}})", ov.held);
  }
  out += R"(],"arms":[)";
  first = true;
  for (const ArmView& arm : frame.arms) {
    RMPMARL_ASSERT(arm.world != nullptr, "EncodeFrame: an arm without a world");
    if (!first) out += ',';
    first = false;
    const sim::World& world = *arm.world;
    const sim::WorldModel& wm = world.model();
    const mjData* d = world.mj_data();
    out += R"({"links":[)";
    const int num_links = wm.kinematic_model().num_links();
    for (int k = 0; k < num_links; ++k) {
      const int b = wm.link_body(k);
      const double* x = d->xpos + 3 * b;
      const double* q = d->xquat + 4 * b;
      fmt::format_to(o, "{}[{:.4f},{:.4f},{:.4f},{:.5f},{:.5f},{:.5f},{:.5f}]", k > 0 ? "," : "", x[0], x[1], x[2],
                     q[0], q[1], q[2], q[3]);
    }
    out += R"(],"q":[)";
    for (int i = 0; i < world.nq(); ++i) fmt::format_to(o, "{}{:.4f}", i > 0 ? "," : "", world.q()[i]);
    out += R"(],"ee":)";
    AppendVec(out, arm.p_WE);
    fmt::format_to(o, R"(,"error":{:.4f},"clearance":)", (arm.p_WE - frame.p_WT).norm());
    AppendNumber(out, arm.clearance);
    fmt::format_to(o, R"(,"collisions":{},"step_us":{:.1f},"witness":[)", arm.collisions, arm.step_us);
    bool first_w = true;
    auto witness = [&](int joint, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double dist) {
      if (!first_w) out += ',';
      first_w = false;
      fmt::format_to(o, R"({{"joint":{},"a":)", joint);
      AppendVec(out, a);
      out += R"(,"b":)";
      AppendVec(out, b);
      fmt::format_to(o, R"(,"d":{:.4f}}})", dist);
    };
    if (arm.learned != nullptr) {
      const control::JointAgents& agents = arm.learned->agents();
      for (int i = 0; i < agents.nq(); ++i) {
        const control::JointWarning& w = agents.warning(i);
        if (w.present && w.partner == sim::PartnerKind::kObstacle) witness(i, w.p_W1, w.p_W2, w.distance);
      }
    } else {
      // the nearest warning per (capsule, obstacle) pair
      const std::span<const control::WarningContact> warnings = arm.warnings;
      int shown = 0;
      for (std::size_t n = 0; n < warnings.size() && shown < 64; ++n) {
        const sim::WarningContact& w = warnings[n];
        if (w.other_kind != sim::PartnerKind::kObstacle) continue;
        bool nearest = true;
        for (const sim::WarningContact& u : warnings) {
          if (&u != &w && u.other_kind == w.other_kind && u.capsule == w.capsule && u.other_index == w.other_index &&
              (u.distance < w.distance || (u.distance == w.distance && &u < &w))) {
            nearest = false;
            break;
          }
        }
        if (!nearest) continue;
        witness(-1, w.p_W1, w.p_W2, w.distance);
        ++shown;
      }
    }
    out += R"(],"joints":)";
    if (arm.learned == nullptr) {
      out += "null";
    } else {
      const control::JointAgents& agents = arm.learned->agents();
      out += '[';
      for (int i = 0; i < agents.nq(); ++i) {
        const control::OptionMachine& m = agents.option_machine(i);
        const rmp::JointLayerWeights& w = agents.layer_weights(i);
        fmt::format_to(o, R"({}{{"option":{},"phase_b":{},"params":[{:.3f},{:.3f},{:.3f},{:.3f}]}})", i > 0 ? "," : "",
                       m.option(), m.phase_b(), w.target_accel_scale, w.target_metric_scale, w.collision_accel_scale,
                       w.collision_metric_scale);
      }
      out += ']';
    }
    out += '}';
  }
  out += "]}";
}

double Clearance(const sim::World& world, std::span<const ObstacleView> obstacles) {
  // the capsules where the simulator has their links' bodies
  const collision::RobotCollisionModel& checker = world.model().collision();
  const mjData* d = world.mj_data();
  std::vector<Eigen::Isometry3d> X_WL(world.model().robot().model.num_links(), Eigen::Isometry3d::Identity());
  for (const collision::RobotCollisionModel::LinkGroup& group : checker.link_groups()) {
    const int b = world.model().link_body(group.link);
    X_WL[group.link].linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d->xmat + 9 * b);
    X_WL[group.link].translation() = Eigen::Map<const Eigen::Vector3d>(d->xpos + 3 * b);
  }
  collision::RobotCollisionData placed(checker);
  collision::PlaceRobot(checker, X_WL, &placed);
  double clearance = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < obstacles.size(); ++k) {
    clearance = collision::CalcObstacleClearance(checker, placed, obstacles[k].obstacle, static_cast<int>(k),
                                                 -std::numeric_limits<double>::infinity(), clearance);
  }
  return clearance;
}

std::string EncodeError(std::string_view message) {
  return json({{"type", "error"}, {"message", std::string(message)}}).dump(-1, ' ', false,
                                                                           json::error_handler_t::replace);
}

}  // namespace rmpmarl::viewer
