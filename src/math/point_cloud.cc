// Point-cloud index: a kd-tree with node bounding boxes, and exact segment → nearest-point queries.
#include "rmpmarl/math/point_cloud.h"

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::math {
namespace {

// The segment of a query, with what every point test needs precomputed.
struct Segment {
  double ax, ay, az, dx, dy, dz, dd;  // A, B − A, |B − A|²
  Segment(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
      : ax(a.x()), ay(a.y()), az(a.z()), dx(b.x() - a.x()), dy(b.y() - a.y()), dz(b.z() - a.z()),
        dd(dx * dx + dy * dy + dz * dz) {}
};

// squared distance of (px, py, pz) to the segment and the segment parameter of its closest point. The index and the
// brute force call this same function on the same doubles, so their distances agree bit for bit.
inline double SquaredDistance(const Segment& s, double px, double py, double pz, double* t_out) {
  const double wx = px - s.ax, wy = py - s.ay, wz = pz - s.az;
  double t = 0.0;
  if (s.dd > 0.0) t = std::clamp((wx * s.dx + wy * s.dy + wz * s.dz) / s.dd, 0.0, 1.0);
  const double ex = wx - t * s.dx, ey = wy - t * s.dy, ez = wz - t * s.dz;
  *t_out = t;
  return ex * ex + ey * ey + ez * ez;
}

SegmentNearestPoint Finish(const Segment& s, int index, double d2, double t, const Eigen::Vector3d& p) {
  SegmentNearestPoint r;
  r.index = index;
  r.distance = std::sqrt(d2);
  r.t = t;
  r.p_Wsegment = Eigen::Vector3d(s.ax + t * s.dx, s.ay + t * s.dy, s.az + t * s.dz);
  r.p_Wpoint = p;
  return r;
}

// a lower bound of the squared distance between the segment and any point in the box [lo, hi]: the larger of the
// gap between the segment's own bounding box and the box, and the distance from the box's centre to the segment
// minus the box's half diagonal.
inline double LowerBound2(const Segment& s, const Eigen::Vector3d& seg_lo, const Eigen::Vector3d& seg_hi,
                          const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  double gap2 = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double g = std::max({0.0, lo[k] - seg_hi[k], seg_lo[k] - hi[k]});
    gap2 += g * g;
  }
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  double t;
  const double dc = std::sqrt(SquaredDistance(s, c.x(), c.y(), c.z(), &t)) - 0.5 * (hi - lo).norm();
  const double sphere2 = dc > 0.0 ? dc * dc : 0.0;
  return std::max(gap2, sphere2);
}

}  // namespace

PointCloudIndex::PointCloudIndex(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, int leaf_size) {
  Build(p_W, leaf_size);
}

void PointCloudIndex::Reserve(int num_points) {
  const size_t n = static_cast<size_t>(std::max(0, num_points));
  x_.reserve(n);
  y_.reserve(n);
  z_.reserve(n);
  original_index_.reserve(n);
  work_.reserve(n);
  // leaves hold between leaf_size / 2 and leaf_size points, so there are at most 2n + 1 leaves for leaf_size 1 and
  // fewer nodes than twice the leaves
  nodes_.reserve(4 * n + 2);
}

void PointCloudIndex::Build(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, int leaf_size) {
  RMPMARL_ASSERT(leaf_size >= 1, "PointCloudIndex::Build: leaf_size must be at least 1");
  const int n = static_cast<int>(p_W.cols());
  nodes_.clear();
  bounds_.setEmpty();
  work_.resize(n);
  x_.resize(n);
  y_.resize(n);
  z_.resize(n);
  original_index_.resize(n);
  if (n == 0) return;
  RMPMARL_ASSERT(p_W.allFinite(), "PointCloudIndex::Build: every point must be finite");
  // the points are partitioned in place, coordinates and index together: the selections read contiguous memory
  for (int i = 0; i < n; ++i) work_[i] = {{p_W(0, i), p_W(1, i), p_W(2, i)}, i};
  BuildNode(0, n, leaf_size);
  // the coordinates in tree order: each leaf's points contiguous
  for (int k = 0; k < n; ++k) {
    x_[k] = work_[k].p[0];
    y_[k] = work_[k].p[1];
    z_[k] = work_[k].p[2];
    original_index_[k] = work_[k].index;
  }
  bounds_ = Eigen::AlignedBox3d(nodes_[0].lo, nodes_[0].hi);
}

int PointCloudIndex::BuildNode(int begin, int end, int leaf_size) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<double>::infinity();
    hi[a] = -lo[a];
  }
  for (int k = begin; k < end; ++k) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], work_[k].p[a]);
      hi[a] = std::max(hi[a], work_[k].p[a]);
    }
  }
  nodes_[id].lo = Eigen::Vector3d(lo[0], lo[1], lo[2]);
  nodes_[id].hi = Eigen::Vector3d(hi[0], hi[1], hi[2]);
  nodes_[id].begin = begin;
  nodes_[id].end = end;
  if (end - begin <= leaf_size) return id;
  int axis = 0;
  (nodes_[id].hi - nodes_[id].lo).maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(work_.begin() + begin, work_.begin() + mid, work_.begin() + end,
                   [axis](const BuildPoint& a, const BuildPoint& b) {
                     return a.p[axis] < b.p[axis] || (a.p[axis] == b.p[axis] && a.index < b.index);
                   });
  const int left = BuildNode(begin, mid, leaf_size);
  const int right = BuildNode(mid, end, leaf_size);
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

Eigen::Vector3d PointCloudIndex::point(int i) const {
  RMPMARL_ASSERT(i >= 0 && i < size(), "PointCloudIndex::point: index out of range");
  // original_index_ maps reordered → original; find the reordered slot (tests and diagnostics only)
  const auto it = std::find(original_index_.begin(), original_index_.end(), i);
  const size_t k = static_cast<size_t>(it - original_index_.begin());
  return {x_[k], y_[k], z_[k]};
}

SegmentNearestPoint PointCloudIndex::NearestToSegment(const Eigen::Vector3d& p_WA, const Eigen::Vector3d& p_WB) const {
  if (nodes_.empty()) return {};
  const Segment s(p_WA, p_WB);
  const Eigen::Vector3d seg_lo = p_WA.cwiseMin(p_WB), seg_hi = p_WA.cwiseMax(p_WB);
  double best2 = std::numeric_limits<double>::infinity(), best_t = 0.0;
  int best_k = -1, best_index = std::numeric_limits<int>::max();
  // a node is skipped only when its lower bound exceeds the best distance by more than rounding could explain
  auto beaten = [&best2](double lb2) { return lb2 > best2 * (1.0 + 1e-12) + 1e-30; };
  struct Entry {
    int node;
    double lb2;
  };
  // depth ≤ log2(N) + 1 for median splits; 2 entries per level
  Entry stack[160];
  int top = 0;
  stack[top++] = {0, 0.0};
  while (top > 0) {
    const Entry e = stack[--top];
    if (beaten(e.lb2)) continue;
    const Node& node = nodes_[e.node];
    if (node.left < 0) {
      for (int k = node.begin; k < node.end; ++k) {
        double t;
        const double d2 = SquaredDistance(s, x_[k], y_[k], z_[k], &t);
        const int index = original_index_[k];
        if (d2 < best2 || (d2 == best2 && index < best_index)) {
          best2 = d2;
          best_t = t;
          best_k = k;
          best_index = index;
        }
      }
      continue;
    }
    const Node& l = nodes_[node.left];
    const Node& r = nodes_[node.right];
    const double lb_l = LowerBound2(s, seg_lo, seg_hi, l.lo, l.hi);
    const double lb_r = LowerBound2(s, seg_lo, seg_hi, r.lo, r.hi);
    RMPMARL_ASSERT(top + 2 <= static_cast<int>(std::size(stack)), "PointCloudIndex: tree deeper than expected");
    // the nearer child is popped first
    if (lb_l <= lb_r) {
      stack[top++] = {node.right, lb_r};
      stack[top++] = {node.left, lb_l};
    } else {
      stack[top++] = {node.left, lb_l};
      stack[top++] = {node.right, lb_r};
    }
  }
  return Finish(s, best_index, best2, best_t, Eigen::Vector3d(x_[best_k], y_[best_k], z_[best_k]));
}

SegmentNearestPoint NearestToSegmentBruteForce(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W,
                                               const Eigen::Vector3d& p_WA, const Eigen::Vector3d& p_WB) {
  const int n = static_cast<int>(p_W.cols());
  if (n == 0) return {};
  const Segment s(p_WA, p_WB);
  double best2 = std::numeric_limits<double>::infinity(), best_t = 0.0;
  int best = -1;
  for (int i = 0; i < n; ++i) {
    double t;
    const double d2 = SquaredDistance(s, p_W(0, i), p_W(1, i), p_W(2, i), &t);
    if (d2 < best2) {  // strict: the lowest index wins a tie
      best2 = d2;
      best_t = t;
      best = i;
    }
  }
  return Finish(s, best, best2, best_t, p_W.col(best));
}

DistanceResult CapsulePointCloudDistance(const Capsule& capsule, const PointCloudIndex& cloud, double point_radius) {
  RMPMARL_ASSERT(!cloud.empty(), "CapsulePointCloudDistance: empty cloud");
  const SegmentNearestPoint near = cloud.NearestToSegment(capsule.p_WA, capsule.p_WB);
  DistanceResult r;
  const Eigen::Vector3d diff = near.p_Wsegment - near.p_Wpoint;
  if (near.distance > kGeometryTouchTolerance) {
    r.n_W = diff / near.distance;
  } else {
    const Eigen::Vector3d d = capsule.p_WB - capsule.p_WA;
    r.n_W = d.squaredNorm() > 0.0 ? Eigen::Vector3d(d.unitOrthogonal()) : Eigen::Vector3d::UnitZ();
  }
  r.distance = near.distance - capsule.radius - point_radius;
  r.p_W1 = near.p_Wsegment - capsule.radius * r.n_W;
  r.p_W2 = near.p_Wpoint + point_radius * r.n_W;
  return r;
}

}  // namespace rmpmarl::math
