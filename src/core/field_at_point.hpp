// The scalar field of Solenthaler et al. (docs/design.md §3.3) at one point off the lattice, in
// double, for the host stages that need it between lattice points (the gradient normals,
// host/vertex_normals.cpp). The device computes the field on the lattice (kernels/scalar_field.cl);
// the plain C++ reference (src/reference/) keeps its own literal copy as the kernels' oracle.
#pragma once

#include <cstddef>

#include <glm/glm.hpp>

namespace trilevel {

/// Largest real part of the eigenvalues of J by the closed-form cubic of kernels/scalar_field.cl,
/// in double: several times faster than the reference's QR iterations, which the tests compare it with.
double largest_real_eigenvalue_cubic(const double J[3][3]);

/// phi at a point x from the offsets y_j = x_j - x of its particles (those with |y_j| < R; the
/// support's cut rim is dropped as on the device), summed in the given order: |xbar - x| - r f(EVmax),
/// f the radius factor of the largest real eigenvalue of grad xbar (largest_real_eigenvalue_cubic);
/// +R where no particle has weight. r: particle radius, R: support radius, world units.
double field_from_offsets(const glm::dvec3* y, std::size_t count, double r, double R);

}  // namespace trilevel
