// A planner user: links rmpmarl::planning alone (no simulator) and plans the installed planar2 arm around a sphere
// that blocks the straight way from q = (0, 0) to q = (3, 0) (the outstretched arm sweeps through it); expects a path
// of more than two waypoints.
#include <cstdio>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/planning/rrt.h"

int main() {
  const auto robot = rmpmarl::kinematics::MakePlanar2();
  rmpmarl::planning::RrtOptions options;
  options.check_floor = false;  // a planar arm in the z = 0 plane
  options.planning_time_budget = 10.0;
  options.planning_iterations = 5000;
  rmpmarl::planning::RrtPolicy planner(robot, options);
  rmpmarl::rmp::Scene scene;
  scene.obstacles.push_back(rmpmarl::rmp::Obstacle::MakeSphere(Eigen::Vector3d(0.0, 0.8, 0.0), 0.1));
  const Eigen::VectorXd start = Eigen::VectorXd::Zero(2);
  const Eigen::VectorXd goal = Eigen::Vector2d(3.0, 0.0);
  const auto path = planner.PlanPath(start, goal, scene);
  std::printf("planar2 around a sphere: %zu waypoints\n", path.size());
  return path.size() > 2 ? 0 : 1;
}
