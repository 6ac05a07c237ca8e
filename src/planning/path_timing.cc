// The timing of joint paths as the RRT baseline and the plan follower execute them; see path_timing.h.
#include "rmpmarl/planning/path_timing.h"

#include <algorithm>

#include "rmpmarl/common/error.h"

namespace rmpmarl::planning {

std::vector<double> PathArrivalTimes(const std::vector<Eigen::VectorXd>& path, const Eigen::VectorXd& speeds) {
  std::vector<double> times(path.size(), 0.0);
  for (size_t k = 1; k < path.size(); ++k) {
    const double duration = ((path[k] - path[k - 1]).cwiseAbs().cwiseQuotient(speeds)).maxCoeff();
    times[k] = times[k - 1] + std::max(duration, 1e-6);
  }
  return times;
}

std::vector<double> PathArcLengths(const std::vector<Eigen::VectorXd>& path) {
  std::vector<double> s(path.size(), 0.0);
  for (size_t k = 1; k < path.size(); ++k) s[k] = s[k - 1] + (path[k] - path[k - 1]).norm();
  return s;
}

PathLocation LocateOnPath(const std::vector<double>& knots, double x) {
  RMPMARL_ASSERT(knots.size() >= 2, "LocateOnPath: a path of at least two waypoints");
  const int last = static_cast<int>(knots.size()) - 1;
  PathLocation at;
  at.segment =
      std::clamp(static_cast<int>(std::upper_bound(knots.begin(), knots.end(), x) - knots.begin()) - 1, 0, last - 1);
  const double length = knots[at.segment + 1] - knots[at.segment];
  at.fraction = length > 0.0 ? std::clamp((x - knots[at.segment]) / length, 0.0, 1.0) : 0.0;
  return at;
}

void SamplePath(const std::vector<Eigen::VectorXd>& path, const std::vector<double>& times, double t,
                Eigen::VectorXd* q_d, Eigen::VectorXd* qd_d) {
  RMPMARL_ASSERT(!path.empty() && times.size() == path.size(), "SamplePath: a path and its times");
  const int last = static_cast<int>(path.size()) - 1;
  if (t >= times[last]) {
    *q_d = path[last];
    qd_d->setZero(path[last].size());
    return;
  }
  const PathLocation at = LocateOnPath(times, t);  // every segment lasts > 0 (PathArrivalTimes)
  const int segment = at.segment;
  *q_d = path[segment] + at.fraction * (path[segment + 1] - path[segment]);
  *qd_d = (path[segment + 1] - path[segment]) / (times[segment + 1] - times[segment]);
}

}  // namespace rmpmarl::planning
