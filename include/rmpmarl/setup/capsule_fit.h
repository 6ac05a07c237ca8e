#pragma once
/// Capsules fitted to link geometry: the smallest capsule (by volume) covering a URDF primitive, and a capsule fitted
/// to a set of balls (mesh vertices are balls of radius 0). Frame F is the frame the inputs are expressed in (the
/// primitive's own frame for the closed forms, usually the link frame L for point sets); the result is in F.
///
/// Covering a set of balls {(p_i, ρ_i)} with the capsule (segment [a, b] on a line through o with direction u,
/// radius R): ball i is covered iff dist(p_i, [a, b]) ≤ R − ρ_i. With t_i = u·(p_i − o) and d_i the distance of p_i
/// from the line, a segment [t_a, t_b] covers every ball for a given R ≥ max(d_i + ρ_i) iff
///   t_b ≥ max_i (t_i − s_i),  t_a ≤ min_i (t_i + s_i),  s_i = √((R − ρ_i)² − d_i²),
/// so the shortest segment is [min(t_i + s_i), max(t_i − s_i)] (a sphere when that interval is empty) and the
/// volume πR²|b − a| + 4/3 πR³ is a function of R alone, minimised numerically on [R₀, R_sphere].
#include <Eigen/Geometry>
#include <vector>

#include "rmpmarl/math/geometry.h"

namespace rmpmarl::setup {

/// volume of a capsule: π r² |b − a| + 4/3 π r³.
double CapsuleVolume(const math::Capsule& capsule);

/// distance from point p_F to the capsule's surface, negative inside.
double CapsuleSignedDistance(const math::Capsule& capsule, const Eigen::Vector3d& p_F);

/// the sphere itself (a capsule of zero length) centred at the origin.
math::Capsule CapsuleCoveringSphere(double radius);

/// smallest capsule covering a cylinder of `radius` and `length` along z, centred at the origin (URDF <cylinder>).
/// Closed-form family: axis z, ends at ±(h − s), radius R = √(r² + s²), h = length/2; s ∈ [0, h] minimises the
/// volume V(s) = 2πR²(h − s) + 4/3 πR³ (a scan, then golden-section search; dV/ds = 2π[2s(h − s) − R² + 2sR] < 0 at
/// s = 0, so the optimum always pulls the ends in a little; s = h is the circumscribed sphere).
math::Capsule CapsuleCoveringCylinder(double radius, double length);

/// smallest capsule covering a box of full side lengths `size` centred at the origin (URDF <box size>): the cylinder
/// family around each of the three box axes with the cross-section's half diagonal as radius; the smallest of the three.
math::Capsule CapsuleCoveringBox(const Eigen::Vector3d& size);

/// a capsule of `radius` and cylinder `length` along z, centred at the origin (URDF/SDF <capsule>): itself.
math::Capsule CapsuleCoveringCapsule(double radius, double length);

/// A ball to cover: a mesh vertex has radius 0.
struct Ball {
  Eigen::Vector3d p_F = Eigen::Vector3d::Zero();
  double radius = 0.0;
};

/// Options of FitCapsuleToBalls.
struct CapsuleFitOptions {
  /// candidate axes: the three principal axes of the centres' covariance (largest variance first); more axes are
  /// tried around each (±angle_step, two rings) when refine_axis is set.
  bool refine_axis = true;
  double angle_step = 0.08;  ///< [rad] first ring of the axis refinement; halved on each of the refinement rounds
  int refine_rounds = 4;
};

/// smallest capsule (by volume) covering every ball, over the candidate axes (see CapsuleFitOptions); for each axis
/// the axis line passes through the centre of the smallest circle enclosing the balls' projections, and R is chosen
/// by the one-dimensional volume minimisation in the file comment. Every ball is covered exactly (up to rounding).
/// Throws InputError for an empty set or non-finite input.
math::Capsule FitCapsuleToBalls(const std::vector<Ball>& balls, const CapsuleFitOptions& options = {});

/// the principal axes of the balls' centres, one per column, by increasing variance (the eigenvectors of their
/// covariance).
Eigen::Matrix3d PrincipalAxes(const std::vector<Ball>& balls);

/// the same for points (balls of radius 0), one per column.
math::Capsule FitCapsuleToPoints(const Eigen::Matrix3Xd& p_F, const CapsuleFitOptions& options = {});

/// smallest capsule covering the balls with its axis along the unit vector u_F (used by the fit and its tests).
math::Capsule FitCapsuleAlongAxis(const std::vector<Ball>& balls, const Eigen::Vector3d& u_F);

}  // namespace rmpmarl::setup
