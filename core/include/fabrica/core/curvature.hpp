// Second- and third-order surface geometry (docs/algorithms.md §2):
// Rusinkiewicz (3DPVT 2004) per-face fit of the second fundamental form from
// vertex-normal differences, re-expressed at vertices with corner-area
// weights, and the per-face fit of the curvature-derivative tensor from
// curvature differences. The Surface caches the results; this header adds
// the helpers other modules need to use them (evaluating the derivative
// tensor, diagonalising tangent tensors), optional smoothing (rtsc style,
// §2.7) and the feature size (§2.6).
//
// Conventions (as trimesh2/rtsc): the shape operator is S = D n of the
// outward normal, so convex is positive (sphere of radius R: +1/R);
// |k1| >= |k2|; e2 = n x e1; (a,b,c,d) = C(e1,e1,e1), C(e1,e1,e2),
// C(e1,e2,e2), C(e2,e2,e2). Units: curvature 1/mm, derivatives 1/mm².
//
// Differences from trimesh2 2.16 (on purpose): double precision; the 3x3
// normal equations of the per-face fit are solved correctly (trimesh2's
// small-matrix LDLᵀ computes its last pivot too early, biasing curvature
// low on anisotropic triangles, see docs/algorithms.md Appendix A); vertex
// averages are normalised by the weights of the faces actually used.
#pragma once

#include <cstdint>

#include "fabrica/core/surface.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

/// A symmetric tangent tensor [[xx, xy], [xy, yy]] in an orthonormal frame.
struct TangentTensor2 {
  double xx = 0.0, xy = 0.0, yy = 0.0;
};

/// Eigen-decomposition of a symmetric 2x2 tensor in the frame (u, v = n x u):
/// k1, k2 ordered by absolute value (|k1| >= |k2|), e1 the unit direction of
/// k1 (a combination of u and v), e2 = n x e1.
struct PrincipalFrame {
  double k1 = 0.0, k2 = 0.0;
  Vec3 e1 = Vec3::Zero(), e2 = Vec3::Zero();
};
PrincipalFrame diagonalize(const TangentTensor2& tensor, const Vec3& u, const Vec3& v,
                           const Vec3& normal);

/// C(x, y, z) for 2D vectors in the principal frame (x = (x1, x2) means
/// x1 e1 + x2 e2) of the symmetric trilinear form with coefficients a,b,c,d.
inline double curvature_derivative_form(double a, double b, double c, double d, const Vec2& x,
                                        const Vec2& y, const Vec2& z) {
  return a * x[0] * y[0] * z[0] +
         b * (x[0] * y[0] * z[1] + x[0] * y[1] * z[0] + x[1] * y[0] * z[0]) +
         c * (x[0] * y[1] * z[1] + x[1] * y[0] * z[1] + x[1] * y[1] * z[0]) +
         d * x[1] * y[1] * z[1];
}

/// D_u kappa(u) = C(u,u,u) for u = (u1, u2) in the principal frame
/// (docs/algorithms.md §2.4): the derivative along u of the normal curvature in
/// direction u (u need not be unit; the result scales with |u|^3).
inline double curvature_derivative_along(double a, double b, double c, double d, double u1,
                                         double u2) {
  return u1 * u1 * (a * u1 + 3.0 * b * u2) + u2 * u2 * (3.0 * c * u1 + d * u2);
}

/// Smooths a curvature field in place (rtsc's diffuse_curv, docs/algorithms.md
/// §2.7): each vertex averages the second fundamental forms of the vertices
/// reachable through edges within 2.5 sigma (Euclidean distance), weighted by
/// exp(-d²/(2 sigma²)) * A_j * (n_i . n_j) (neighbours with n_i . n_j <= 0 are
/// skipped), each re-expressed in the centre's tangent plane first, then
/// re-diagonalises. Invalid vertices stay as they are and are not used.
/// sigma in mm (> 0, else nothing happens).
void smooth_curvature(const Surface& surface, PrincipalCurvatures& curvature, double sigma,
                      int passes = 1);

/// Same smoothing for the derivative tensor; each neighbour's C is
/// re-expressed in the centre's principal frame (cubic rule) before
/// averaging. `curvature` supplies the principal frames.
void smooth_curvature_derivatives(const Surface& surface, const PrincipalCurvatures& curvature,
                                  CurvatureDerivatives& derivatives, double sigma, int passes = 1);

struct FeatureSizeOptions {
  /// Fraction used as the percentile of |k1|, |k2| (rtsc: 0.1).
  double percentile = 0.1;
  /// rtsc's constants: s = min(numerator / kappa_percentile, cap * R).
  double numerator = 0.01;
  double bounding_sphere_fraction = 0.05;
  /// false (default): every valid vertex contributes (deterministic, no
  /// sampling noise). true: rtsc's sample of 500 vertices from its fixed
  /// linear congruential generator (r <- 1664525 r + 1013904223, r0 = 0,
  /// index r mod nv), invalid samples skipped.
  bool rtsc_sampling = false;
};

/// Feature size (docs/algorithms.md §2.6) from per-vertex curvature: the
/// `percentile` value kappa_p of all |k1| and |k2| at valid vertices, then
/// min(0.01 / kappa_p, 0.05 R). Returns 0.05 R when kappa_p is 0 or no
/// vertex is valid, and 1 (mm) when R is 0 (empty or single-point mesh), so
/// the result is always positive and finite.
double feature_size(const PrincipalCurvatures& curvature, double bounding_sphere_radius,
                    const FeatureSizeOptions& options = {});

}  // namespace fabrica
