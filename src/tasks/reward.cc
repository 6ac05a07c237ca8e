// Reward terms of eq (14).
#include "rmpmarl/tasks/reward.h"

#include "rmpmarl/common/error.h"

namespace rmpmarl::tasks {

void JointReachRewards(const Eigen::Vector3d& e_W, const Eigen::Ref<const Eigen::Matrix3Xd>& J_WE,
                       const Eigen::Ref<const Eigen::VectorXd>& dq, double tolerance, Eigen::Ref<Eigen::VectorXd> R) {
  RMPMARL_DASSERT(J_WE.cols() == dq.size() && R.size() == dq.size(), "JointReachRewards: size mismatch");
  Eigen::Vector3d t = e_W;  // t_i: the sub-target of joint i
  for (Eigen::Index i = 0; i < dq.size(); ++i) {
    const Eigen::Vector3d step = J_WE.col(i) * dq[i];
    R[i] = (t - step).norm() <= t.norm() - tolerance ? 1.0 : 0.0;
    t -= step;
  }
}

double DistanceReward(double d_prev, double d, double unit) { return (d_prev - d) / unit; }

ReachCycleTracker::ReachCycleTracker(double reach_tolerance, double reach_release, double time_reward)
    : tolerance_(reach_tolerance), release_(reach_release), reward_(time_reward) {}

void ReachCycleTracker::Reset() {
  reached_ = false;
  steps_ = 0;
  cycles_ = 0;
  previous_ = std::numeric_limits<double>::infinity();
}

double ReachCycleTracker::Update(double d) {
  if (reached_) {
    if (d > release_) {  // the target got away: a new cycle starts with this step
      reached_ = false;
      steps_ = 1;
    }
    return 0.0;
  }
  ++steps_;
  if (d > tolerance_) return 0.0;
  reached_ = true;
  ++cycles_;
  const double length = steps_;
  const double r = length < previous_ ? reward_ : 0.0;
  previous_ = length;
  steps_ = 0;
  return r;
}

}  // namespace rmpmarl::tasks
