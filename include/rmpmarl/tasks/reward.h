#pragma once
/// The reward of eq (14) (docs/environments.md, "Reward"):  r = Σ_i δ_i R_i + γ_d R_d + R_t − φ.
/// Every term is a pure function or a small tracker here, so tests can check them against hand-computed values.
#include <Eigen/Core>
#include <limits>

#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::tasks {

/// The four logged terms of one step (their sum is the reward).
struct RewardTerms {
  double joint_reach = 0.0;  ///< Σ δ_i R_i
  double distance = 0.0;     ///< γ_d R_d
  double time = 0.0;         ///< R_t
  double collision = 0.0;    ///< −φ · (collision events this step)

  double total() const { return joint_reach + distance + time + collision; }
};

/// Per-joint reach rewards with sequential sub-targets, bottom joint first:
///   t_0 = e = p_T − p_E (at the start of the step),  t_i = e − Σ_{k<i} j_k Δq_k,
///   R_i = 1 if ‖t_i − j_i Δq_i‖ ≤ ‖t_i‖ − η, else 0,
/// where j_k is column k of the end-effector position Jacobian at the start of the step and Δq_k joint k's commanded
/// displacement of the step (the agent's motion output). So each joint's goal is what is left of the end-effector
/// error after the joints below it have moved, and it earns 1 when its own first-order end-effector motion brings
/// the end effector at least η closer to that goal. Writes R (size nq, preallocated); allocates nothing.
void JointReachRewards(const Eigen::Vector3d& e_W, const Eigen::Ref<const Eigen::Matrix3Xd>& J_WE,
                       const Eigen::Ref<const Eigen::VectorXd>& dq, double tolerance, Eigen::Ref<Eigen::VectorXd> R);

/// R_d = (d_prev − d)/unit: +1 per `unit` (0.1 cm) the end-effector–target distance shrank, −1 per unit it grew.
double DistanceReward(double d_prev, double d, double unit);

/// The time reward R_t over reach cycles. A cycle starts at the episode start and whenever the end effector leaves
/// the target after a reach (d > reach_release); it completes at the first step with d ≤ reach_tolerance, and its
/// length is the number of env steps since it started. A completed cycle shorter than the previous completed one
/// earns time_reward (the first completed cycle of an episode is compared with +∞, so it always earns it).
class ReachCycleTracker {
 public:
  ReachCycleTracker() = default;
  ReachCycleTracker(double reach_tolerance, double reach_release, double time_reward);
  /// starts an episode: a cycle begins now.
  void Reset();
  /// one env step ended at distance d; returns R_t of the step.
  double Update(double d);

  bool reached() const { return reached_; }
  int cycles_completed() const { return cycles_; }
  /// length of the last completed cycle (+∞ before the first).
  double previous_cycle_steps() const { return previous_; }

 private:
  double tolerance_ = 0.02, release_ = 0.04, reward_ = 25.0;
  bool reached_ = false;
  int steps_ = 0;
  int cycles_ = 0;
  double previous_ = std::numeric_limits<double>::infinity();
};

}  // namespace rmpmarl::tasks
