// The RRT baseline's search: validity of configurations and segments through the robot collision checker, OMPL's
// RRT-Connect in joint space with a seeded sampler, and shortcutting (greedy and random).
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <utility>

#include "rmpmarl/common/random.h"
#include "rrt_impl.h"

namespace rmpmarl::planning {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;
using rrt_internal::kInf;

// OMPL's uniform sampler with an instance seed (ompl::RNG::setLocalSeed) instead of one drawn from the process-wide
// seed generator: RRT-Connect's only random choice, so a plan is a function of (problem, seed).
class SeededSampler final : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, std::uint_fast32_t seed) : ob::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

}  // namespace

double RrtPolicy::Impl::Clearance(const Eigen::Ref<const Eigen::VectorXd>& q, bool obstacles_only,
                                  double stop_below, ClearancePair* pair) {
  collision::PlaceRobot(checker, q, &placed);
  const double d = collision::CalcObstacleClearance(checker, placed, obstacles, stop_below, kInf, pair);
  if (obstacles_only || d <= stop_below) return d;
  return SelfClearance(stop_below, d, pair);
}

double RrtPolicy::Impl::SelfClearance(double stop_below, double d, ClearancePair* pair) const {
  return collision::CalcSelfClearance(checker, placed, stop_below, d, pair);
}

bool RrtPolicy::Impl::SegmentValid(const Eigen::VectorXd& a, const Eigen::VectorXd& b, bool obstacles_only,
                                   bool within_limits) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / options.validity_resolution)));
  // coarse to fine: a shortcut through an obstacle fails at one of its first states (the answer is the same)
  return collision::VisitEdgeStatesCoarseToFine(n, [&](int k) {
    scratch = a + (static_cast<double>(k) / n) * (b - a);
    if (within_limits && !Within(scratch, limit_lower, limit_upper)) return false;
    return split_margins ? ValidRelaxed(scratch, obstacles_only) : CollisionFree(scratch, obstacles_only);
  });
}

std::vector<Eigen::VectorXd> RrtPolicy::Impl::Plan(const Eigen::VectorXd& q_start, const Eigen::VectorXd& q_goal) {
  SetBounds(q_start);
  if (!Valid(q_start) || !Valid(q_goal)) return {};
  if (SegmentValid(q_start, q_goal, false)) return {q_start, q_goal};

  auto space = std::make_shared<ob::RealVectorStateSpace>(nq);
  ob::RealVectorBounds bounds(nq);
  for (int i = 0; i < nq; ++i) {
    bounds.setLow(i, lower[i]);
    bounds.setHigh(i, upper[i]);
  }
  space->setBounds(bounds);
  const auto sampler_seed = static_cast<std::uint_fast32_t>(SplitMix64(seed ^ SplitMix64(plans)) & 0xffffffffULL);
  space->setStateSamplerAllocator(
      [sampler_seed](const ob::StateSpace* s) { return std::make_shared<SeededSampler>(s, sampler_seed); });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker([this](const ob::State* state) {
    const double* v = state->as<ob::RealVectorStateSpace::StateType>()->values;
    const Eigen::Map<const Eigen::VectorXd> q(v, nq);
    return split_margins ? ValidRelaxed(q, false) : CollisionFree(q, false);
  });
  si->setStateValidityCheckingResolution(options.validity_resolution / space->getMaximumExtent());
  si->setup();

  auto to_state = [&](const Eigen::VectorXd& q, ob::ScopedState<ob::RealVectorStateSpace>* s) {
    for (int i = 0; i < nq; ++i) (*s)[i] = q[i];
  };
  ob::ScopedState<ob::RealVectorStateSpace> start(space), goal(space);
  to_state(q_start, &start);
  to_state(q_goal, &goal);
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  pdef->setStartAndGoalStates(start, goal, 1e-9);
  og::RRTConnect planner(si);
  if (options.range > 0.0) planner.setRange(options.range);
  planner.setProblemDefinition(pdef);
  planner.setup();
  ob::PlannerTerminationCondition budget = ob::timedPlannerTerminationCondition(options.planning_time_budget);
  if (options.planning_iterations > 0) {
    // RRT-Connect evaluates the condition once per iteration
    budget = ob::plannerOrTerminationCondition(
        budget, ob::PlannerTerminationCondition([n = options.planning_iterations, calls = 0]() mutable {
          return ++calls > n;
        }));
  }
  const ob::PlannerStatus status = planner.solve(budget);
  if (status != ob::PlannerStatus::EXACT_SOLUTION) return {};

  const auto& states = std::static_pointer_cast<og::PathGeometric>(pdef->getSolutionPath())->getStates();
  std::vector<Eigen::VectorXd> path;
  path.reserve(states.size() + 1);
  for (const ob::State* s : states) {
    path.emplace_back(Eigen::Map<const Eigen::VectorXd>(s->as<ob::RealVectorStateSpace::StateType>()->values, nq));
  }
  path.back() = q_goal;  // exact goal (the goal threshold lets RRT-Connect stop a hair away)
  Shortcut(&path);
  if (options.shortcut_iterations > 0) RandomShortcut(&path, SplitMix64(sampler_seed ^ 0x5348525443555453ULL));
  return path;
}

void RrtPolicy::Impl::RandomShortcut(std::vector<Eigen::VectorXd>* path, std::uint64_t seed) {
  std::mt19937_64 draw(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> s = PathArcLengths(*path);
  // the point at arc length t and the index of the segment holding it
  auto at = [&](double t, Eigen::VectorXd* q) {
    const PathLocation where = LocateOnPath(s, t);
    const size_t k = static_cast<size_t>(where.segment);
    *q = (*path)[k] + where.fraction * ((*path)[k + 1] - (*path)[k]);
    return k;
  };
  Eigen::VectorXd a, b;
  for (int it = 0; it < options.shortcut_iterations && path->size() >= 3; ++it) {
    double ta = unit(draw) * s.back(), tb = unit(draw) * s.back();
    if (ta > tb) std::swap(ta, tb);
    const size_t ka = at(ta, &a), kb = at(tb, &b);
    if (kb <= ka) continue;  // on one segment: straight already
    // a → b replaces the waypoints ka+1 … kb when it is valid and shorter
    if ((b - a).norm() >= tb - ta - 1e-9 || !SegmentValid(a, b, false)) continue;
    std::vector<Eigen::VectorXd> out;
    out.reserve(path->size() + 2);
    out.insert(out.end(), path->begin(), path->begin() + static_cast<std::ptrdiff_t>(ka) + 1);
    if ((a - out.back()).norm() > 1e-12) out.push_back(a);
    if ((b - (*path)[kb + 1]).norm() > 1e-12) out.push_back(b);
    out.insert(out.end(), path->begin() + static_cast<std::ptrdiff_t>(kb) + 1, path->end());
    *path = std::move(out);
    s = PathArcLengths(*path);
  }
}

void RrtPolicy::Impl::Shortcut(std::vector<Eigen::VectorXd>* path) {
  // greedy: from each kept waypoint jump to the farthest later one that a straight valid segment reaches
  std::vector<Eigen::VectorXd> out;
  out.reserve(path->size());
  out.push_back(path->front());
  size_t i = 0;
  while (i + 1 < path->size()) {
    size_t j = path->size() - 1;
    while (j > i + 1 && !SegmentValid((*path)[i], (*path)[j], false)) --j;
    out.push_back((*path)[j]);
    i = j;
  }
  *path = std::move(out);
}

}  // namespace rmpmarl::planning
