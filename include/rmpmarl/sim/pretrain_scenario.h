#pragma once
/// The pre-training scenario of the paper (IV.A) as a sim::Scenario: a target ball without collision volume in
/// uniform linear motion in a random in-plane direction (reflected in the workspace box), and one cube placed on the
/// target's path (or, with `obstacle_path_offset`, beside it), so tracking the target means going around the cube
/// (or passing it closely). Domain randomisation per episode: target
/// start and direction (Scenario helpers), speed, the cube's position along the path, its (optional) velocity, and
/// the start configuration (SetNextStart, pre-training only).
#include <Eigen/Core>
#include <string_view>

#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::sim {

/// the position reached after t seconds by a point starting at p with velocity v that reflects at the faces of
/// `box` (as sim::Scenario::Advance moves the target); along degenerate box axes the coordinate is pinned.
Eigen::Vector3d ReflectedPosition(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double t,
                                  const Eigen::AlignedBox3d& box);

/// the direction of motion after t seconds of the same reflected point (unit; zero where v is zero).
Eigen::Vector3d ReflectedDirection(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double t,
                                   const Eigen::AlignedBox3d& box);

/// the smallest distance between an axis-aligned cube (centre c, half side h) and the reflected path of (p, v) over
/// [0, duration], sampled every 2 mm of travel.
double PathCubeClearance(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double duration,
                         const Eigen::AlignedBox3d& box, const Eigen::Vector3d& c, double h);

/// throws InputError naming `where` and the field unless the options are in range (the workspace is checked where
/// it is computed).
void ValidatePretrainScenarioOptions(const PretrainScenarioOptions& options, std::string_view where);

/// `pretrain-2link`.
class PretrainScenario final : public Scenario {
 public:
  /// throws InputError for bad options.
  PretrainScenario(const kinematics::Robot& robot, const PretrainScenarioOptions& options);

  /// the start configuration of the following Resets (clamped to the joint limits); empty: the ready posture.
  void SetNextStart(const Eigen::VectorXd& q0);
  /// the ready posture (sim::ReadyConfiguration), around which pre-training randomises q0.
  const Eigen::VectorXd& ready() const { return ready_; }
  const PretrainScenarioOptions& options() const { return options_; }

 private:
  void Draw(std::mt19937_64& rng) override;
  PretrainScenarioOptions options_;
  Eigen::VectorXd ready_;
};

}  // namespace rmpmarl::sim
