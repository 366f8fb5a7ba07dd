// Analytic bodies of the generated scenes; see analytic_bodies.hpp.
#include "analytic_bodies.hpp"

#include <algorithm>
#include <cmath>

namespace trilevel {
namespace {

constexpr double kPi = 3.141592653589793;

// Rounded box: the box shrunk by `edge`, offset by `edge` (the usual box distance, rounded).
glm::dvec3 inner_excess(const AnalyticBody& s, glm::dvec3 p) {
    return glm::abs(p) - glm::dvec3(s.a - s.edge, s.b - s.edge, s.c - s.edge);
}

}  // namespace

double AnalyticBody::signed_distance(glm::dvec3 p) const {
    switch (kind) {
    case Kind::Ball: return glm::length(p) - a;
    case Kind::Torus: return glm::length(glm::dvec2(std::hypot(p.x, p.z) - a, p.y)) - b;
    case Kind::RoundedBox: {
        const glm::dvec3 q = inner_excess(*this, p);
        return glm::length(glm::max(q, glm::dvec3(0.0))) + std::min(std::max({q.x, q.y, q.z}), 0.0) - edge;
    }
    }
    return 0.0;
}

glm::dvec3 AnalyticBody::normal(glm::dvec3 p) const {
    switch (kind) {
    case Kind::Ball: return glm::normalize(p);
    case Kind::Torus: {
        const double rho = std::hypot(p.x, p.z);
        const glm::dvec3 centre = rho > 0 ? glm::dvec3(p.x, 0, p.z) * (a / rho) : glm::dvec3(a, 0, 0);
        return glm::normalize(p - centre);
    }
    case Kind::RoundedBox: {
        const glm::dvec3 q = inner_excess(*this, p);
        glm::dvec3 g = glm::max(q, glm::dvec3(0.0));
        if (g == glm::dvec3(0.0)) {  // inside the inner box: the face of the largest excess
            const int k = q.x >= q.y && q.x >= q.z ? 0 : q.y >= q.z ? 1 : 2;
            g[k] = 1.0;
        }
        for (int k = 0; k < 3; ++k) g[k] = p[k] < 0 ? -g[k] : g[k];
        return glm::normalize(g);
    }
    }
    return {0, 0, 1};
}

double AnalyticBody::volume() const {
    switch (kind) {
    case Kind::Ball: return 4.0 / 3.0 * kPi * a * a * a;
    case Kind::Torus: return 2.0 * kPi * kPi * a * b * b;
    case Kind::RoundedBox: {  // Steiner: inner box, its faces pushed out, quarter cylinders, eighth balls
        const double x = 2 * (a - edge), y = 2 * (b - edge), z = 2 * (c - edge), e = edge;
        return x * y * z + 2 * e * (x * y + y * z + z * x) + kPi * e * e * (x + y + z) + 4.0 / 3.0 * kPi * e * e * e;
    }
    }
    return 0.0;
}

std::optional<AnalyticBody> analytic_body(const std::string& scene, double r) {
    AnalyticBody s;
    if (scene == "ball") {
        s.kind = AnalyticBody::Kind::Ball;
        s.a = 30 * r;
    } else if (scene == "torus") {
        s.kind = AnalyticBody::Kind::Torus;
        s.a = 40 * r;
        s.b = 14 * r;
    } else if (scene == "rounded-box") {
        s.kind = AnalyticBody::Kind::RoundedBox;
        s.a = 30 * r;
        s.b = 20 * r;
        s.c = 15 * r;
        s.edge = 8 * r;
    } else {
        return std::nullopt;
    }
    return s;
}

}  // namespace trilevel
