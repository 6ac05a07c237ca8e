#pragma once
// Pieces shared by the two ways of covering a link (capsule_cover.cc: plane cuts; capsule_cover_inscribed.cc:
// capsules grown inside the solid): the surface samples, the inside test and the measure of a cover.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "rmpmarl/setup/capsule_cover.h"
#include "rmpmarl/math/point_cloud.h"

namespace rmpmarl::setup::internal {

// samples of the geometry's surface no coarser than *spacing (coarser, and *spacing updated, when there would be too
// many): a grid on every triangle, Fibonacci points on every ball.
std::vector<Eigen::Vector3d> SurfaceSamples(const CoverGeometry& g, double* spacing);

Eigen::Matrix3Xd AsMatrix(const std::vector<Eigen::Vector3d>& p);

// the cover's measures over the samples (their index built on the same points); the excess counts only capsule
// surface outside the other capsules and, when `solid` is given, outside the solid.
CapsuleCover Measure(std::vector<math::Capsule> capsules, const std::vector<Eigen::Vector3d>& samples,
                     const math::PointCloudIndex& index, double spacing, double tolerance, const SolidTest* solid);

// capsules grown inside the solid, each sticking out by at most options.tolerance (see CoverMethod::kInscribed);
// nothing when more than options.max_capsules would be needed.
std::optional<std::vector<math::Capsule>> FitInscribedCapsules(const CoverGeometry& g,
                                                               const CapsuleCoverOptions& options,
                                                               const std::vector<Eigen::Vector3d>& samples,
                                                               const math::PointCloudIndex& index,
                                                               const SolidTest& solid);

}  // namespace rmpmarl::setup::internal
