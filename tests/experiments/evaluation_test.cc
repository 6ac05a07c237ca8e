// The experiments' measuring instrument: identical episodes for every method, seeds that never meet training
// seeds, thread-count independence, and the confidence intervals against hand-computed values.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <random>
#include <set>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/evaluation.h"
#include "rmpmarl/experiments/statistics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/tasks/task_episode.h"
#include "rmpmarl/control/controller.h"

namespace rmpmarl::experiments {
namespace {

tasks::TaskConfig SmallTask(tasks::TaskKind kind, int max_steps) {
  tasks::TaskConfig c = tasks::DefaultTaskConfig(kind);
  c.randomization.variants = 3;
  c.episode.max_steps = max_steps;
  return c;
}

TEST(EpisodeSeedTest, DeterministicDistinctAndNeverATrainingSeed) {
  std::set<std::uint64_t> seen;
  for (std::uint64_t s : {0ull, 1ull, 20231001ull}) {
    for (int i = 0; i < 2000; ++i) {
      const std::uint64_t e = EpisodeSeed(s, i);
      EXPECT_EQ(e, EpisodeSeed(s, i));
      EXPECT_GE(e, std::uint64_t{1} << 32);  // training env seeds are seed + s·num_envs + k < 2^32
      EXPECT_TRUE(seen.insert(e).second);
    }
  }
}

// Every interface mode and the external baselines start episode i of a seed in the same state, and the scenario
// (target and obstacle paths) evolves identically whatever the robot does, until an obstacle hits the robot.
TEST(IdenticalEpisodesTest, EveryMethodSeesTheSameEpisode) {
  tasks::TaskConfig base = SmallTask(tasks::TaskKind::kReachAvoid, 60);
  base.scenario.crossing.num_obstacles = 2;
  std::vector<std::unique_ptr<tasks::ManipulatorEnv>> envs;
  for (tasks::InterfaceMode mode : {tasks::InterfaceMode::kPerJointRmp, tasks::InterfaceMode::kDirect,
                                 tasks::InterfaceMode::kPerJointDirect}) {
    tasks::TaskConfig c = base;
    c.interface = mode;
    envs.push_back(std::make_unique<tasks::ManipulatorEnv>(tasks::MakeTaskContext(c)));
  }
  tasks::ControllerMaker rmpflow;
  rmpflow.make_policy = [](const kinematics::Robot& robot) {
    return std::make_unique<control::RmpflowAccelerationPolicy>(robot, 4);
  };
  tasks::ControllerEpisodes baseline(tasks::MakeTaskContext(base), rmpflow);

  for (int episode = 0; episode < 6; ++episode) {
    std::vector<std::unique_ptr<tasks::StepBuffers>> buffers;
    std::vector<std::mt19937_64> rngs;
    for (auto& env : envs) {
      buffers.push_back(std::make_unique<tasks::StepBuffers>(env->spec()));
      rngs.emplace_back(EpisodeSeed(7, episode));
      env->Reset(rngs.back(), buffers.back()->out());
    }
    const tasks::ManipulatorEnv& ref = *envs[0];
    for (size_t k = 1; k < envs.size(); ++k) {
      const tasks::ManipulatorEnv& e = *envs[k];
      EXPECT_EQ(e.variant(), ref.variant());
      EXPECT_EQ(e.scenario_setting(), ref.scenario_setting());
      EXPECT_EQ(e.world().q(), ref.world().q());
      EXPECT_EQ(e.world().qd(), ref.world().qd());
      EXPECT_EQ(e.scenario().target().p_WT, ref.scenario().target().p_WT);
      EXPECT_EQ(e.scenario().target().v_WT, ref.scenario().target().v_WT);
      for (int j = 0; j < ref.scenario().num_obstacles(); ++j) {
        EXPECT_EQ(e.scenario().obstacles()[j].p_WO(), ref.scenario().obstacles()[j].p_WO());
        EXPECT_EQ(e.scenario().obstacles()[j].v_WO(), ref.scenario().obstacles()[j].v_WO());
      }
    }
    const Eigen::VectorXd q0 = ref.world().q(), qd0 = ref.world().qd();
    // 30 steps with different actions per method: the target moves identically
    for (int t = 0; t < 30; ++t) {
      for (size_t k = 0; k < envs.size(); ++k) {
        std::vector<float> a(static_cast<size_t>(envs[k]->spec().num_agents) * envs[k]->spec().action.size(),
                             static_cast<float>(k % 2));
        envs[k]->Step(a.data(), rngs[k], buffers[k]->out());
      }
    }
    for (size_t k = 1; k < envs.size(); ++k) {
      EXPECT_EQ(envs[k]->scenario().target().p_WT, ref.scenario().target().p_WT) << "env " << k;
    }
    // RMPflow on the task's episodes: the same start, the same target after 30 control steps
    std::mt19937_64 rng(EpisodeSeed(7, episode));
    int frames = 0;
    baseline.Run(rng, {.video_fps = 1000.0, .on_frame = [&](const sim::FrameInfo& f) {
                         ++frames;
                         if (f.index == 0) {
                           EXPECT_EQ(baseline.episode().variant(), ref.variant());
                           EXPECT_EQ(baseline.episode().setting(), ref.scenario_setting());
                           EXPECT_EQ(f.world->q(), q0);
                           EXPECT_EQ(f.world->qd(), qd0);
                           for (int j = 0; j < ref.scenario().num_obstacles(); ++j) {
                             EXPECT_EQ(f.scenario->obstacles()[j].v_WO(), ref.scenario().obstacles()[j].v_WO());
                           }
                         }
                         if (f.index == 30) {
                           EXPECT_EQ(f.scenario->target().p_WT, ref.scenario().target().p_WT);
                         }
                       }});
    EXPECT_GT(frames, 30);
  }
}

TEST(EvaluateMethodTest, ResultsDoNotDependOnTheThreadCountAndRecordTheEpisode) {
  const tasks::TaskConfig task = SmallTask(tasks::TaskKind::kLineCrossing, 80);
  const Method basic = Method::FixedOption("basic", 0);
  const auto one = EvaluateMethod(basic, task, {.episodes = 5, .eval_seed = 3, .jobs = 1});
  const auto two = EvaluateMethod(basic, task, {.episodes = 5, .eval_seed = 3, .jobs = 2});
  ASSERT_EQ(one.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(one[i].index, i);
    EXPECT_EQ(one[i].episode_seed, EpisodeSeed(3, i));
    EXPECT_EQ(one[i].metrics.collisions, two[i].metrics.collisions);
    EXPECT_EQ(one[i].metrics.mean_tracking_error, two[i].metrics.mean_tracking_error);
    EXPECT_EQ(one[i].variant, two[i].variant);
    EXPECT_EQ(one[i].setting, two[i].setting);
    EXPECT_EQ(one[i].metrics.length, 80);
    EXPECT_GT(one[i].control_step_us, 0.0);
  }
}

TEST(EvaluateMethodTest, RmpflowConvergesOnTheTargetAndTheBasicLayerStaysCollisionFree) {
  tasks::TaskConfig task = SmallTask(tasks::TaskKind::kReachAvoid, 300);
  task.scenario.crossing.num_obstacles = 0;
  // measured (eval seed 1, 3 s episodes): RMPflow ends within 0.1–4.0 mm of the moving target; its settled error
  // (t >= 1 s) is 30–110 mm because it needs 1–2 s to get there
  for (const EpisodeRecord& r : EvaluateMethod(Method::Rmpflow(), task, {.episodes = 4, .eval_seed = 1, .jobs = 2})) {
    EXPECT_TRUE(r.metrics.success);
    EXPECT_LT(1000.0 * r.metrics.final_tracking_error, 10.0);
    EXPECT_LT(1000.0 * r.metrics.settled_tracking_error, 1000.0 * r.metrics.mean_tracking_error);
  }
  for (const EpisodeRecord& r :
       EvaluateMethod(Method::FixedOption("basic", 0), task, {.episodes = 4, .eval_seed = 1, .jobs = 2})) {
    EXPECT_TRUE(r.metrics.success);
    EXPECT_TRUE(std::isfinite(r.metrics.settled_tracking_error));
  }
}

TEST(EvaluateMethodTest, APolicyOfTheWrongShapeIsRejectedWithAMessage) {
  const tasks::TaskConfig task = SmallTask(tasks::TaskKind::kReachAvoid, 10);
  EXPECT_THROW(EvaluateMethod(Method::Policy("x", "/nonexistent.rmpp", tasks::InterfaceMode::kDirect), task, {}),
               InputError);
  EXPECT_THROW(Method::FixedOption("bad", 3), InputError);
  EXPECT_THROW(EvaluateMethod(Method::Rmpflow(), task, {.episodes = 0}), InputError);
}

// The hand-gated fixed option (Method::ThreatGate) reads the look-ahead block: a gate that always fires is the fixed
// option with the threat parameters, one that never fires is the fixed option with the clear ones, and on fast
// crossings a 15 cm gate fires in some episodes and not in others.
TEST(EvaluateMethodTest, ThreatGateSwitchesBetweenItsTwoParameterSets) {
  tasks::TaskConfig task = SmallTask(tasks::TaskKind::kLineCrossing, 150);
  task.scenario.line_speeds = {1.8};
  auto lookahead = [](tasks::TaskConfig& t) { t.observation.lookahead = 1.0; };
  std::array<float, control::RmpActionLayout::kNumContinuous> clear{}, threat{};
  clear[0] = 1.0f;    // target accel scale x4
  threat[2] = -1.0f;  // collision accel scale / 4
  Method clear_fixed = Method::FixedOption("clear", 2), threat_fixed = Method::FixedOption("threat", 2);
  clear_fixed.fixed_parameters = clear;
  threat_fixed.fixed_parameters = threat;
  clear_fixed.adjust_task = threat_fixed.adjust_task = lookahead;
  auto gate = [&](double clearance) {
    Method m = Method::FixedOption("gate", 2);
    m.fixed_parameters = clear;
    m.threat_gate = Method::ThreatGate{clearance, threat};
    m.adjust_task = lookahead;
    return m;
  };
  EvalProtocol protocol;
  protocol.episodes = 4;
  protocol.eval_seed = 11;
  const auto always = EvaluateMethod(gate(100.0), task, protocol), never = EvaluateMethod(gate(-100.0), task, protocol);
  const auto sometimes = EvaluateMethod(gate(0.15), task, protocol);
  const auto c = EvaluateMethod(clear_fixed, task, protocol), t = EvaluateMethod(threat_fixed, task, protocol);
  int fired = 0, held = 0;  // episodes that differ from the clear / the threat parameters
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(always[i].metrics.mean_tracking_error, t[i].metrics.mean_tracking_error);
    EXPECT_EQ(always[i].metrics.min_clearance, t[i].metrics.min_clearance);
    EXPECT_EQ(never[i].metrics.mean_tracking_error, c[i].metrics.mean_tracking_error);
    EXPECT_EQ(never[i].metrics.min_clearance, c[i].metrics.min_clearance);
    const double m = 1000.0 * sometimes[i].metrics.mean_tracking_error;
    fired += m != 1000.0 * c[i].metrics.mean_tracking_error ? 1 : 0;
    held += m != 1000.0 * t[i].metrics.mean_tracking_error ? 1 : 0;
  }
  // measured (seed 11): two episodes whose arm works near the line's path (the gate fires), two away from it
  EXPECT_GE(fired, 1);
  EXPECT_GE(held, 1);
  EXPECT_NE(1000.0 * c[0].metrics.mean_tracking_error, 1000.0 * t[0].metrics.mean_tracking_error);
  // without the look-ahead block the gate has nothing to read
  Method blind = gate(0.15);
  blind.adjust_task = nullptr;
  EXPECT_THROW(EvaluateMethod(blind, task, protocol), InputError);
  Method gated_rmpflow = Method::Rmpflow();
  gated_rmpflow.threat_gate = Method::ThreatGate{0.15, threat};
  EXPECT_THROW(EvaluateMethod(gated_rmpflow, task, protocol), InputError);
}

TEST(StatisticsTest, WilsonMatchesHandComputedIntervals) {
  // 8 of 10, z = 1.96: centre (0.8 + 0.19207) / 1.38415 = 0.71674, half 1.96 √(0.016 + 0.0096) / 1.38415 =
  // 0.22657 → [0.4902, 0.9433]  (E. B. Wilson 1927)
  const Interval a = WilsonInterval(8, 10);
  EXPECT_NEAR(a.value, 0.8, 1e-12);
  EXPECT_NEAR(a.low, 0.4902, 2e-4);
  EXPECT_NEAR(a.high, 0.9433, 2e-4);
  // 0 of 20: [0, z²/(n + z²)] = [0, 0.1611]
  const Interval b = WilsonInterval(0, 20);
  EXPECT_NEAR(b.low, 0.0, 1e-12);
  EXPECT_NEAR(b.high, 3.8415 / 23.8415, 2e-4);
  EXPECT_TRUE(std::isnan(WilsonInterval(0, 0).value));
}

TEST(StatisticsTest, BootstrapIntervalCoversTheMeanAndShrinksWithTheSample) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n(10.0, 2.0);
  std::vector<double> small(20), large(2000);
  for (double& x : small) x = n(rng);
  for (double& x : large) x = n(rng);
  const Interval s = BootstrapMeanInterval(small, 1), l = BootstrapMeanInterval(large, 1);
  EXPECT_LE(s.low, s.value);
  EXPECT_GE(s.high, s.value);
  // the 95 % half width ≈ 1.96 σ / √n: 0.88 for n = 20, 0.088 for n = 2000
  EXPECT_NEAR(s.high - s.low, 2 * 1.96 * 2.0 / std::sqrt(20.0), 0.45);
  EXPECT_NEAR(l.high - l.low, 2 * 1.96 * 2.0 / std::sqrt(2000.0), 0.03);
  const Interval c = BootstrapMeanInterval({3.0, 3.0, NAN, 3.0}, 1);
  EXPECT_EQ(c.value, 3.0);
  EXPECT_EQ(c.low, 3.0);
  EXPECT_EQ(c.high, 3.0);
  EXPECT_EQ(BootstrapMeanInterval(small, 9).low, BootstrapMeanInterval(small, 9).low);  // seeded
}

TEST(StatisticsTest, SeedIntervalUsesStudentT) {
  // {0.8, 0.6, 0.7}: mean 0.7, s = 0.1, t(0.975, 2) = 4.303 → half width 4.303 · 0.1 / √3 = 0.2484
  const Interval i = SeedMeanInterval({0.8, 0.6, 0.7});
  EXPECT_NEAR(i.value, 0.7, 1e-12);
  EXPECT_NEAR(i.high - i.value, 0.24844, 1e-4);
  EXPECT_NEAR(i.value - i.low, 0.24844, 1e-4);
  EXPECT_TRUE(std::isnan(SeedMeanInterval({0.5}).low));
  EXPECT_EQ(FiniteMedian({4.0, 1.0, NAN, 3.0, 2.0}), 2.5);
  EXPECT_EQ(FiniteMedian({3.0, 1.0, 2.0}), 2.0);
  EXPECT_EQ(LabelSeed("a|b"), LabelSeed("a|b"));
  EXPECT_NE(LabelSeed("a|b"), LabelSeed("a|c"));
}

// seeds that disagree: the two-level bootstrap carries the spread between groups, the pooled one does not
TEST(StatisticsTest, HierarchicalBootstrapCarriesTheSpreadBetweenSeeds) {
  std::mt19937_64 rng(8);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<std::vector<double>> groups(3);
  std::vector<double> pooled;
  const double centres[] = {10.0, 14.0, 18.0};
  for (int g = 0; g < 3; ++g) {
    for (int k = 0; k < 100; ++k) {
      groups[g].push_back(centres[g] + noise(rng));
      pooled.push_back(groups[g].back());
    }
  }
  const Interval flat = BootstrapMeanInterval(pooled, 3), nested = HierarchicalBootstrapMeanInterval(groups, 3);
  EXPECT_NEAR(nested.value, flat.value, 1e-12);
  EXPECT_GT(nested.high - nested.low, 5.0 * (flat.high - flat.low));
  EXPECT_LE(nested.low, 12.0);
  EXPECT_GE(nested.high, 16.0);
  // one group: the plain bootstrap
  const Interval single = HierarchicalBootstrapMeanInterval({groups[0]}, 3);
  EXPECT_EQ(single.low, BootstrapMeanInterval(groups[0], 3).low);
}


TEST(EvaluationTest, SplitByReferenceMatchesEpisodesByIndex) {
  auto record = [](int index, int collisions, double settled) {
    EpisodeRecord r;
    r.index = index;
    r.metrics.collisions = collisions;
    r.metrics.success = collisions == 0;
    r.metrics.settled_tracking_error = settled / 1000.0;
    return r;
  };
  // the reference collides in episodes 1 and 3
  const std::vector<EpisodeRecord> reference = {record(0, 0, 5), record(1, 2, 90), record(2, 0, 7), record(3, 1, 80)};
  // a method's episodes, in another order and pooled over two seeds (each index twice); one NaN settled value
  const std::vector<EpisodeRecord> method = {record(3, 0, 40), record(0, 0, 10), record(1, 1, 60), record(2, 0, 20),
                                             record(0, 0, 30), record(1, 0, std::nan("")), record(2, 0, 10),
                                             record(3, 0, 20)};
  const EpisodeSplit s = SplitByReference(method, reference);
  EXPECT_EQ(s.free_count, 4);
  EXPECT_EQ(s.blocked_count, 4);
  EXPECT_DOUBLE_EQ(s.free_success, 1.0);
  EXPECT_DOUBLE_EQ(s.blocked_success, 0.75);
  EXPECT_DOUBLE_EQ(s.free_settled_mm, (10.0 + 20.0 + 30.0 + 10.0) / 4);
  EXPECT_DOUBLE_EQ(s.blocked_settled_mm, (40.0 + 60.0 + 20.0) / 3);  // the NaN is left out
  const EpisodeSplit none = SplitByReference({}, reference);
  EXPECT_EQ(none.free_count + none.blocked_count, 0);
  EXPECT_TRUE(std::isnan(none.free_success));
  EXPECT_THROW(SplitByReference({record(7, 0, 1)}, reference), InputError);
  EXPECT_THROW(SplitByReference({}, {record(0, 0, 1), record(0, 1, 2)}), InputError);  // a reference index twice
}

// A sensor that tells the controllers the exact shapes and counts its calls: the sensed path of the evaluation.
class PassThroughSensor final : public sim::ObstacleSensor {
 public:
  explicit PassThroughSensor(std::atomic<long>* senses) : senses_(senses) {}
  void Reset(const sim::World&) override {}
  void Sense(const sim::World&, rmp::Scene*) override { ++*senses_; }
  const Eigen::Matrix3Xd& points() const override { return none_; }
  sim::SensorSummary Summary() const override { return {}; }

 private:
  std::atomic<long>* senses_;
  Eigen::Matrix3Xd none_{3, 0};
};

// The controllers are told what a sensor gives them: through a sensor that passes the truth on, RMPflow's episodes
// and the learned agents' (as control::LearnedController) are the episodes without one, bit for bit; fixed-option methods,
// which read MuJoCo's contacts, are refused.
TEST(SensedEvaluationTest, APassThroughSensorChangesNothingAndFixedOptionsAreRefused) {
  const std::string path = (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string();
  tasks::TaskConfig task = rl::PolicyTaskConfig(control::LoadPolicyFile(path), path);
  task.episode.max_steps = 60;
  std::atomic<long> senses{0};
  EvalProtocol exact;
  exact.episodes = 3;
  exact.eval_seed = 5;
  exact.learned_as_controller = true;
  EvalProtocol sensed = exact;
  sensed.make_sensor = [&senses](const sim::WorldModel&) { return std::make_unique<PassThroughSensor>(&senses); };
  const Method learned = Method::Policy("learned", path, task.interface);
  for (const Method& m : {Method::Rmpflow("rmpflow"), learned}) {
    SCOPED_TRACE(m.name);
    const long before = senses;
    const auto a = EvaluateMethod(m, task, exact), b = EvaluateMethod(m, task, sensed);
    EXPECT_EQ(senses - before, 3 * 60) << "one Sense per control step";
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(a[i].metrics.mean_tracking_error, b[i].metrics.mean_tracking_error);
      EXPECT_EQ(a[i].metrics.min_clearance, b[i].metrics.min_clearance);
    }
  }
  // as a controller the learned agents are the agents in the env, episode for episode: both sense their warning
  // contacts from the capsules and the scene once per control step (sim::EpisodeLoop, control::WarningSensor)
  EvalProtocol env = exact;
  env.learned_as_controller = false;
  const auto in_env = EvaluateMethod(learned, task, env), as_controller = EvaluateMethod(learned, task, exact);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(in_env[i].metrics.mean_tracking_error, as_controller[i].metrics.mean_tracking_error) << i;
    EXPECT_EQ(in_env[i].metrics.min_clearance, as_controller[i].metrics.min_clearance) << i;
    // the task's reward scores both (its sensing agents never act in the controller's run: the last bits may move)
    EXPECT_NEAR(in_env[i].metrics.episode_return, as_controller[i].metrics.episode_return,
                1e-9 * std::abs(in_env[i].metrics.episode_return)) << i;
  }
  EXPECT_THROW(EvaluateMethod(Method::FixedOption("fixed", 0), task, sensed), InputError);
}

}  // namespace
}  // namespace rmpmarl::experiments
