// The RRT baseline's goal configuration: damped-least-squares IK of the end-effector position from several seeds,
// keeping collision-free solutions.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <random>

#include "rrt_impl.h"

namespace rmpmarl::planning {

using rrt_internal::kInf;

Eigen::Vector3d RrtPolicy::Impl::EndEffector(const Eigen::Ref<const Eigen::VectorXd>& q) {
  kinematics::CalcForwardKinematics(robot.model, q, &kin);
  return kinematics::CalcPointPosition(kin, robot.end_effector.link, robot.end_effector.X_LE.translation());
}

double RrtPolicy::Impl::RunDls(Eigen::VectorXd* q, const Eigen::Vector3d& p_WT) {
  const int link = robot.end_effector.link;
  const Eigen::Vector3d p_LE = robot.end_effector.X_LE.translation();
  const double lambda2 = options.ik_damping * options.ik_damping;
  const double converged = 0.1 * options.ik_tolerance;
  double error = kInf;
  for (int it = 0; it <= options.ik_iterations; ++it) {
    kinematics::CalcForwardKinematics(robot.model, *q, &kin);
    const Eigen::Vector3d e = p_WT - kinematics::CalcPointPosition(kin, link, p_LE);
    error = e.norm();
    if (error <= converged || it == options.ik_iterations) break;
    kinematics::CalcPointJacobian(robot.model, kin, link, p_LE, J_WE);
    // damped least squares (Wampler 1986): Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e
    const Eigen::Matrix3d A = J_WE * J_WE.transpose() + lambda2 * Eigen::Matrix3d::Identity();
    scratch.noalias() = J_WE.transpose() * A.ldlt().solve(e);
    const double largest = scratch.cwiseAbs().maxCoeff();
    if (largest > options.ik_max_step) scratch *= options.ik_max_step / largest;
    *q = (*q + scratch).cwiseMax(lower).cwiseMin(upper);
  }
  return error;
}

IkResult RrtPolicy::Impl::SolveIk(const Eigen::Ref<const Eigen::VectorXd>& q_start, const Eigen::Vector3d& p_WT) {
  SetBounds(q_start);
  IkResult best;
  double best_distance = kInf;
  Eigen::VectorXd q(nq);
  for (int s = 0; s < options.ik_seeds; ++s) {
    if (s == 0) {
      q = q_start.cwiseMax(lower).cwiseMin(upper);
    } else if (s == 1 && has_previous_goal) {
      for (int i = 0; i < nq; ++i) {  // the previous goal, continuous joints taken the short way from q_start
        q[i] = continuous[i] ? q_start[i] + std::remainder(previous_goal[i] - q_start[i], 2.0 * M_PI)
                             : previous_goal[i];
      }
      q = q.cwiseMax(lower).cwiseMin(upper);
    } else {
      for (int i = 0; i < nq; ++i) q[i] = std::uniform_real_distribution<double>(lower[i], upper[i])(rng);
    }
    const double error = RunDls(&q, p_WT);
    if (!Valid(q)) continue;
    const bool reached = error <= options.ik_tolerance;
    const double distance = (q - q_start).norm();
    // reached solutions beat unreached ones; among reached the closest to q_start, among unreached the most accurate
    const bool better = !best.found || (reached && !best.reached) ||
                        (reached && best.reached && distance < best_distance) ||
                        (!reached && !best.reached && error < best.error);
    if (better) {
      best = {true, reached, q, error};
      best_distance = distance;
    }
  }
  return best;
}

}  // namespace rmpmarl::planning
