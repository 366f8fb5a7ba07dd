// Measures of a mesh's quality as a rendered surface: against the exact surface of an analytic
// body (analytic_bodies.hpp) where one is known, and from the mesh alone otherwise. Used by the
// smoothing tests and by bench/mesh_quality.cpp.
#pragma once

#include <cstddef>
#include <vector>

#include "analytic_bodies.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

struct MeshQuality {
    std::size_t vertices = 0, triangles = 0;
    bool closed = false;               ///< is_closed_and_oriented
    std::size_t components = 0;        ///< connected components (mesh_components)
    std::vector<long long> euler;      ///< V - E + F per component
    double sliver_share = 0;           ///< share of triangles with an angle under 10 degrees (or zero area)
    double min_angle_deg = 0;          ///< smallest triangle angle
    double volume = 0;                 ///< enclosed volume, world units (signed: outward orientation > 0)
    double volume_ratio = 0;           ///< volume / (particles (2r)^3); 0 without particles
    // Against the body (NaN without one):
    double normal_rms_deg = 0;         ///< area-weighted RMS angle between face normals and the exact normals
    double surface_offset = 0;         ///< fitted offset of the surface from the body, in r (see surface_rms)
    double surface_rms = 0;            ///< RMS distance to the fitted body, in r: the body offset, moved and (a
                                       ///< torus) its major radius changed to fit best (area-weighted least
                                       ///< squares of the signed distance, to first order in the changes)
};

/// Measures `mesh`. `particles` (may be 0) and r give the volume ratio; `body` (may be null) the
/// errors against the exact surface, sampled at the triangles' corners and centroids with area
/// weights (normals at the centroids).
MeshQuality mesh_quality(const Mesh& mesh, double r, std::size_t particles, const AnalyticBody* body);


}  // namespace trilevel
