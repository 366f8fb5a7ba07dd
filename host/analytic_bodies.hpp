// Bodies with a known surface (a ball, a torus, a box with rounded edges) for the generated test
// scenes `ball`, `torus` and `rounded-box` and for measuring meshes against their exact surface
// (mesh_quality.hpp). Lengths in world units; every body is centred on the origin, y up.
#pragma once

#include <optional>
#include <string>

#include <glm/glm.hpp>

namespace trilevel {

struct AnalyticBody {
    enum class Kind { Ball, Torus, RoundedBox };
    Kind kind = Kind::Ball;
    double a = 0, b = 0, c = 0;  ///< ball: radius a; torus: major a, minor b (axis y); box: half-extents a, b, c
    double edge = 0;             ///< rounded box: radius of its rounded edges and corners

    /// Exact signed distance: < 0 inside.
    double signed_distance(glm::dvec3 p) const;
    /// Outward unit normal of the nearest surface point (the distance's gradient).
    glm::dvec3 normal(glm::dvec3 p) const;
    /// Enclosed volume.
    double volume() const;
};

/// The bodies of the generated scenes for particle radius r (sizes in multiples of r): "ball"
/// radius 30r; "torus" major radius 40r, minor 14r; "rounded-box" half-extents 30r x 20r x 15r
/// with edges rounded at 8r. Empty for any other scene name.
std::optional<AnalyticBody> analytic_body(const std::string& scene, double r);

}  // namespace trilevel
