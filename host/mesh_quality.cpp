// Mesh quality measures; see mesh_quality.hpp.
#include "mesh_quality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/glm.hpp>

#include "mesh_topology.hpp"

namespace trilevel {
namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kSliverDeg = 10.0;

glm::dvec3 vertex(const Mesh& m, std::uint32_t v) {
    return {m.positions[3 * std::size_t(v)], m.positions[3 * std::size_t(v) + 1], m.positions[3 * std::size_t(v) + 2]};
}

double angle_at(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) {  // at a
    const glm::dvec3 u = b - a, w = c - a;
    const double lu = glm::length(u), lw = glm::length(w);
    if (lu == 0 || lw == 0) return 0;
    return std::acos(std::clamp(glm::dot(u, w) / (lu * lw), -1.0, 1.0)) * 180.0 / kPi;
}

}  // namespace

MeshQuality mesh_quality(const Mesh& mesh, double r, std::size_t particles, const AnalyticBody* body) {
    MeshQuality q;
    q.vertices = mesh.vertex_count();
    q.triangles = mesh.triangle_count();
    q.closed = is_closed_and_oriented(mesh);
    const MeshComponents comp = mesh_components(mesh);
    q.components = comp.count;
    q.euler = euler_characteristics(mesh, comp);
    for (double v : component_volumes(mesh, comp)) q.volume += v;
    const double particle_volume = 8.0 * r * r * r;
    q.volume_ratio = particles ? q.volume / (double(particles) * particle_volume) : 0.0;

    std::size_t slivers = 0;
    q.min_angle_deg = 180;
    double area = 0, angle2 = 0;
    // The fitted surface: the signed distance d regressed (area-weighted least squares) on
    // (1, n_x, n_y, n_z) and, for a torus, the normal's radial part n_rho: a free offset, a free
    // centre and a free major radius (to first order d changes by -dc.n and -da n_rho).
    const int nf = body && body->kind == AnalyticBody::Kind::Torus ? 5 : 4;
    double M[5][5] = {}, y[5] = {}, dd = 0;
    auto features = [&](glm::dvec3 x, double f[5]) {
        const glm::dvec3 n = body->normal(x);
        f[0] = 1;
        f[1] = n.x;
        f[2] = n.y;
        f[3] = n.z;
        const double rho = std::hypot(x.x, x.z);
        f[4] = rho > 0 ? (n.x * x.x + n.z * x.z) / rho : 0.0;
    };
    const auto& t = mesh.triangles;
    for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
        const glm::dvec3 a = vertex(mesh, t[i]), b = vertex(mesh, t[i + 1]), c = vertex(mesh, t[i + 2]);
        const double angle = std::min({angle_at(a, b, c), angle_at(b, c, a), angle_at(c, a, b)});
        q.min_angle_deg = std::min(q.min_angle_deg, angle);
        const glm::dvec3 n2 = glm::cross(b - a, c - a);
        const double twice = glm::length(n2);
        slivers += angle < kSliverDeg || twice == 0;
        if (!body || twice == 0) continue;
        const double w = 0.5 * twice;
        const glm::dvec3 centroid = (a + b + c) / 3.0;
        const double cosine = std::clamp(glm::dot(n2 / twice, body->normal(centroid)), -1.0, 1.0);
        const double deg = std::acos(cosine) * 180.0 / kPi;
        area += w;
        angle2 += w * deg * deg;
        // Distance: a quadrature of the triangle with the centroid weighted 1/2 and each corner 1/6.
        const double d[4] = {body->signed_distance(centroid), body->signed_distance(a), body->signed_distance(b),
                             body->signed_distance(c)};
        const double wt[4] = {0.5, 1.0 / 6, 1.0 / 6, 1.0 / 6};
        const glm::dvec3 at[4] = {centroid, a, b, c};
        for (int k = 0; k < 4; ++k) {
            double f[5];
            features(at[k], f);
            const double ww = w * wt[k];
            for (int i = 0; i < nf; ++i) {
                for (int j = 0; j < nf; ++j) M[i][j] += ww * f[i] * f[j];
                y[i] += ww * f[i] * d[k];
            }
            dd += ww * d[k] * d[k];
        }
    }
    q.sliver_share = q.triangles ? double(slivers) / double(q.triangles) : 0.0;
    if (body && area > 0) {
        q.normal_rms_deg = std::sqrt(angle2 / area);
        // Solve M theta = y (Gauss-Jordan with partial pivoting; M is symmetric positive definite
        // for any closed surface); the residual is dd - theta . y.
        double A[5][6];
        for (int i = 0; i < nf; ++i) {
            for (int j = 0; j < nf; ++j) A[i][j] = M[i][j];
            A[i][nf] = y[i];
        }
        for (int col = 0; col < nf; ++col) {
            int piv = col;
            for (int i = col + 1; i < nf; ++i)
                if (std::fabs(A[i][col]) > std::fabs(A[piv][col])) piv = i;
            for (int j = 0; j <= nf; ++j) std::swap(A[col][j], A[piv][j]);
            if (A[col][col] == 0) continue;
            for (int i = 0; i < nf; ++i) {
                if (i == col) continue;
                const double f = A[i][col] / A[col][col];
                for (int j = col; j <= nf; ++j) A[i][j] -= f * A[col][j];
            }
        }
        double explained = 0;
        for (int i = 0; i < nf; ++i) explained += (A[i][i] != 0 ? A[i][nf] / A[i][i] : 0.0) * y[i];
        q.surface_offset = (A[0][0] != 0 ? A[0][nf] / A[0][0] : 0.0) / r;
        q.surface_rms = std::sqrt(std::max(0.0, dd - explained) / area) / r;
    } else {
        q.normal_rms_deg = q.surface_offset = q.surface_rms = std::numeric_limits<double>::quiet_NaN();
    }
    return q;
}

}  // namespace trilevel
