#pragma once
/// The timing of joint paths as the RRT baseline (planning/rrt.h) and the plan follower execute them: each straight
/// segment at constant joint velocity, and where a time or an arc length falls on a path.
#include <Eigen/Core>
#include <vector>

namespace rmpmarl::planning {

/// The timing of a joint path as the RRT baseline executes it: each straight segment at constant joint velocity, as
/// fast as the slowest joint allows at `speeds` (per dof, > 0; path_speed_fraction × the velocity limits): the arrival
/// time at each waypoint from the path's start [s] (each segment at least 1 µs).
std::vector<double> PathArrivalTimes(const std::vector<Eigen::VectorXd>& path, const Eigen::VectorXd& speeds);

/// the joint-space arc length at each waypoint of `path` from its start [rad or m].
std::vector<double> PathArcLengths(const std::vector<Eigen::VectorXd>& path);

/// Where a parameter that increases along a path's waypoints (PathArrivalTimes, PathArcLengths) falls on it.
struct PathLocation {
  int segment = 0;        ///< waypoints segment → segment + 1
  double fraction = 0.0;  ///< of the way along it, in [0, 1] (0 on a segment of zero length)
};
/// the segment of `knots` (one per waypoint, increasing, at least two) holding x — the first below them, the last
/// beyond — and x's fraction along it.
PathLocation LocateOnPath(const std::vector<double>& knots, double x);

/// the position q_d and velocity q̇_d at time t of `path` timed by `times` (PathArrivalTimes): the last waypoint at
/// rest from its arrival on. \pre path non-empty, times of its size.
void SamplePath(const std::vector<Eigen::VectorXd>& path, const std::vector<double>& times, double t,
                Eigen::VectorXd* q_d, Eigen::VectorXd* qd_d);

}  // namespace rmpmarl::planning
