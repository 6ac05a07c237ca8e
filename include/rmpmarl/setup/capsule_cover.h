#pragma once
/// Several capsules covering one link's collision geometry: every point of its surface inside one of them (checked on
/// dense surface samples, not assumed), as many capsules as the shape needs for each to stick out beyond the geometry
/// by no more than a tolerance.
///
/// The geometry is a set of triangles (meshes; boxes and cylinders as their triangulated surfaces, a cylinder by a
/// circumscribed prism) and balls (spheres, covered whole). The cover starts from the one smallest capsule
/// (FitCapsuleToBalls) and splits, greedily, the capsule that sticks out farthest: its part of the geometry is cut by
/// a plane, and each side gets its own smallest capsule. A triangle crossing the plane is clipped: each side keeps its
/// convex piece, whose corners (the triangle's corners on that side and the points where its edges cross the plane)
/// are covered, so the convex capsule covers the whole piece and the two sides' capsules overlap along the cut. Of the
/// candidate cuts (seven positions across each of the part's three principal axes and the frame's three axes) the one
/// whose two capsules lie closest to the geometry on average is tried; it is kept when they stick out less than the
/// capsule they replace (at their farthest point by 0.5 mm, or on average by 5 %), otherwise that part stays whole.
///
/// The excess of a capsule is the largest distance from a point of its surface that lies outside every other capsule
/// of the cover to the nearest sample of the geometry's surface; the check is the largest signed distance from any
/// surface sample to the nearest capsule (≤ 0 when the geometry is covered).
#include <Eigen/Core>
#include <vector>

#include "rmpmarl/setup/capsule_fit.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::setup {

/// What to cover, in one frame F (usually the link frame L).
struct CoverGeometry {
  std::vector<Eigen::Vector3d> vertices;     ///< p_F of the triangles' corners
  std::vector<Eigen::Vector3i> triangles;    ///< indices into vertices
  std::vector<Ball> balls;                   ///< spheres, each covered whole
};

/// Whether a point lies inside the solid the geometry bounds (CoverMethod::kInscribed uses it): inside a ball, or
/// inside the triangles by rays along +x, +y and +z (at least two of the three agree: a ray counts as inside when it crosses an odd number of triangles
/// or its signed crossings do not cancel, so overlapping closed meshes and flipped normals both read as solid). A
/// mesh with holes is read approximately; what depends on the answer is only how tight a cover is, never whether it
/// covers.
class SolidTest {
 public:
  explicit SolidTest(const CoverGeometry& g);
  bool Inside(const Eigen::Vector3d& p) const;

 private:
  struct AxisGrid {
    int a = 0, b = 1, c = 2;   // the ray's axis and the two it is projected on
    double lo_b = 0, lo_c = 0, cell = 1;
    int nb = 1, nc = 1;
    std::vector<std::vector<int>> cells;  // triangle indices per (b, c) cell
  };
  bool InsideAlong(const AxisGrid& grid, const Eigen::Vector3d& p) const;

  std::vector<Eigen::Vector3d> vertices_;
  std::vector<Eigen::Vector3i> triangles_;
  std::vector<Ball> balls_;
  AxisGrid grids_[3];
};


/// How FitCapsuleCover places its capsules.
enum class CoverMethod {
  /// plane cuts: the whole link's smallest capsule, split where it sticks out farthest (the file comment); each
  /// capsule holds a convex piece whole, so flat faces and corners are overhung by about a capsule radius
  kCuts,
  /// capsules grown inside the solid: a segment at depth ≥ d below the surface carries radius d + tolerance, so no
  /// capsule sticks out of the solid by more than the tolerance; segments are chosen greedily to cover the surface
  /// samples. Tight at the price of more capsules (flat faces get several side by side); a link needing more than
  /// max_capsules gets the plane cuts' cover instead (reached_max_capsules then says so when it is not within the
  /// tolerance). The excess then counts only capsule surface outside the solid. Needs closed meshes to be tight;
  /// what it covers never depends on that.
  kInscribed,
};

/// Options of FitCapsuleCover.
struct CapsuleCoverOptions {
  CoverMethod method = CoverMethod::kCuts;
  /// a capsule sticking out farther than this beyond the geometry is split [m]
  double tolerance = 0.01;
  int max_capsules = 8;             ///< at most this many capsules
  double sample_spacing = 0.002;    ///< [m] spacing of the surface samples (coarser when there would be > 400 000)
  CapsuleFitOptions fit;            ///< each capsule's own fit
};

/// The cover and its measures.
struct CapsuleCover {
  std::vector<math::Capsule> capsules;
  std::vector<double> excess;       ///< per capsule [m] (see the file comment)
  double max_excess = 0.0;          ///< largest of `excess` [m]
  double mean_excess = 0.0;         ///< the mean over the cover's surface (outside the other capsules) [m]
  /// the check: largest signed distance from a surface sample to the nearest capsule [m]; ≤ 0 when covered
  double max_outside = 0.0;
  int samples = 0;                  ///< surface samples of the check and the excess
  double sample_spacing = 0.0;      ///< their spacing [m]
  bool within_tolerance = false;    ///< max_excess ≤ options.tolerance and every sample inside
  /// the cover stopped at options.max_capsules with a capsule still above the tolerance (otherwise, when not within
  /// it, no cut of those capsules' parts made them stick out less)
  bool reached_max_capsules = false;
};

/// covers `geometry` (see the file comment). Throws InputError for empty or non-finite geometry, triangle indices
/// outside the vertices, or options out of range (tolerance > 0, max_capsules 1 to 256, sample_spacing ≥ 10 µm, the fit's
/// angle_step and refine_rounds).
CapsuleCover FitCapsuleCover(const CoverGeometry& geometry, const CapsuleCoverOptions& options = {});

/// the same measures (excess, check) of given capsules over `geometry`, e.g. of a closed-form capsule or a
/// hand-written set; `options` gives the sample spacing and the tolerance. Throws InputError as FitCapsuleCover, and
/// for no capsule or a non-finite one.
CapsuleCover MeasureCapsuleCover(const CoverGeometry& geometry, std::vector<math::Capsule> capsules,
                                 const CapsuleCoverOptions& options = {});

/// the triangulated surface of a box of full side lengths `size` centred at X_FG's origin, appended to `geometry`.
void AppendBoxSurface(const Eigen::Isometry3d& X_FG, const Eigen::Vector3d& size, CoverGeometry* geometry);

/// the triangulated surface of the prism with `sides` faces circumscribing (so that it covers it) or inscribed in a
/// cylinder of `radius` and `length` along z of G (its corners on the cylinder: samples of the inscribed one lie on
/// or inside the cylinder, what a check of a cover wants), appended to `geometry`.
void AppendCylinderSurface(const Eigen::Isometry3d& X_FG, double radius, double length, int sides, bool circumscribed,
                           CoverGeometry* geometry);

}  // namespace rmpmarl::setup
