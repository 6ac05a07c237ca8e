#pragma once
/// Golden-section search for a minimum of a unimodal function (a convex one, a refined grid minimum), shared by the
/// capsule fits (kinematics/capsule_fit.cc) and the capsule–cylinder distance (math/cylinder.cc).
#include <cmath>

namespace rmpmarl::math {

/// The bracket after a golden-section search: the interval [a, b] and its two inner points with their values.
struct GoldenBracket {
  double a = 0.0, b = 0.0;
  double x1 = 0.0, f1 = 0.0;
  double x2 = 0.0, f2 = 0.0;
};

/// `iterations` golden-section steps for a minimum of f on [a, b] (each shrinks the bracket by 0.618; on a tie
/// f1 = f2 the upper part is kept).
template <typename F>
GoldenBracket GoldenSectionSearch(const F& f, double a, double b, int iterations) {
  const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
  GoldenBracket g{a, b, b - phi * (b - a), 0.0, a + phi * (b - a), 0.0};
  g.f1 = f(g.x1);
  g.f2 = f(g.x2);
  for (int it = 0; it < iterations; ++it) {
    if (g.f1 < g.f2) {
      g.b = g.x2;
      g.x2 = g.x1;
      g.f2 = g.f1;
      g.x1 = g.b - phi * (g.b - g.a);
      g.f1 = f(g.x1);
    } else {
      g.a = g.x1;
      g.x1 = g.x2;
      g.f1 = g.f2;
      g.x2 = g.a + phi * (g.b - g.a);
      g.f2 = f(g.x2);
    }
  }
  return g;
}

}  // namespace rmpmarl::math
