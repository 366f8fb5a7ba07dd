// Weighted Laplacian smoothing with volume correction; see mesh_smoothing.hpp.
#include "mesh_smoothing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/run_beside.hpp"
#include "mesh_topology.hpp"

namespace trilevel {
namespace {

/// Laplacian steps between volume restorations in a long smoothing run (smooth_mesh). Above the
/// default's 12 steps, whose meshes it leaves as they were.
constexpr int kVolumeEvery = 16;

constexpr double kPi = 3.141592653589793;
/// Shares of the flat surface's kernel sum at which a vertex starts to move and moves fully
/// (smoothing_weights): a lone splash particle's vertices see about 0.22 of it and stay put.
constexpr double kWeightLow = 0.45, kWeightHigh = 0.8;

template <class F>
void for_vertices(std::size_t n, F&& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 2048), [&](const auto& range) {
        for (std::size_t v = range.begin(); v != range.end(); ++v) f(v);
    });
}

/// The order in which smoothing_weights sums a vertex's kernel terms: ascending (cell, particle
/// index) over the cells of a dense grid over the mesh's bounding box grown by 2R, with cells of
/// R/2 grown by factors of 1.5 while the box would need more than max(4 count, 2^20) cells, and
/// of the particles in the cells scanned around the vertex's cell (reach ceil(R / cell)). That is
/// the order of the grid the weights had before the frame's particle grid (core/particle_grid.hpp)
/// was shared with the vertex stages: it keeps their bits.
class SumOrder {
public:
    SumOrder(const std::vector<float>& positions, std::size_t count, double R) {
        glm::dvec3 lo(INFINITY), hi(-INFINITY);
        for (std::size_t i = 0; i + 2 < positions.size(); i += 3) {
            const glm::dvec3 p(positions[i], positions[i + 1], positions[i + 2]);
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        lo_ = lo - 2.0 * R;
        const glm::dvec3 extent = hi + 2.0 * R - lo_;
        cell_ = 0.5 * R;
        const double limit = std::max(4.0 * double(count), double(1 << 20));
        while ((std::floor(extent.x / cell_) + 1) * (std::floor(extent.y / cell_) + 1) * (std::floor(extent.z / cell_) + 1) > limit)
            cell_ *= 1.5;
        dims_ = glm::ivec3(glm::floor(extent / cell_)) + 1;
        reach_ = int(std::ceil(R / cell_));
        // Every particle within R of a vertex lies in the box (margin R) and, where R / cell falls
        // short of the reach by more than the rounding of the cell coordinates (under 2^-17 cells
        // for any box of at most 2^34 cells), in the cells scanned around the vertex's cell.
        scans_all_ = double(reach_) - R / cell_ > 0x1p-10;
    }

    /// Whether key() is true for every particle within R (d^2 < R^2) of a vertex.
    bool scans_all() const { return scans_all_; }

    /// The cell of a vertex at p.
    glm::ivec3 of_vertex(glm::dvec3 p) const { return glm::ivec3(glm::floor((p - lo_) / cell_)); }

    /// The sort key of a particle at x for a vertex in cell c; false where it is not summed
    /// (outside the box, or outside the cells scanned around c).
    bool key(glm::ivec3 c, glm::dvec3 x, std::uint64_t& out) const {
        const glm::dvec3 f = (x - lo_) / cell_;
        if (!(f.x >= 0 && f.y >= 0 && f.z >= 0 && f.x < dims_.x && f.y < dims_.y && f.z < dims_.z)) return false;
        const glm::ivec3 k(f);
        const glm::ivec3 from = glm::max(c - reach_, glm::ivec3(0)), to = glm::min(c + reach_, dims_ - 1);
        if (glm::any(glm::lessThan(k, from)) || glm::any(glm::greaterThan(k, to))) return false;
        out = (std::uint64_t(k.z) * std::uint64_t(dims_.y) + std::uint64_t(k.y)) * std::uint64_t(dims_.x) + std::uint64_t(k.x);
        return true;
    }

private:
    double cell_ = 0;
    glm::dvec3 lo_;
    glm::ivec3 dims_{0};
    int reach_ = 1;
    bool scans_all_ = false;
};

/// Compressed rows: the items of row v are item[offset[v] .. offset[v + 1]).
struct Rows {
    std::vector<std::uint32_t> offset, item;
};

/// Triangles around each vertex, ascending; `others` receives, beside each item, the triangle's two
/// other corners (the one after the vertex, then the one before it): item k's at 2k and 2k + 1.
/// One serial sweep over the triangles, so that vertex_neighbours reads its rows in order.
Rows vertex_triangles(const Mesh& mesh, std::vector<std::uint32_t>& others) {
    const std::size_t nv = mesh.vertex_count();
    const auto& t = mesh.triangles;
    Rows g;
    g.offset.assign(nv + 1, 0);
    for (std::size_t i = 0; i < t.size(); ++i) ++g.offset[t[i] + 1];
    for (std::size_t v = 0; v < nv; ++v) g.offset[v + 1] += g.offset[v];
    std::vector<std::uint32_t> fill(g.offset.begin(), g.offset.end() - 1);
    g.item.resize(t.size());
    others.resize(2 * t.size());
    for (std::size_t i = 0; i < t.size(); i += 3)
        for (std::size_t k = 0; k < 3; ++k) {
            const std::uint32_t slot = fill[t[i + k]]++;
            g.item[slot] = std::uint32_t(i / 3);
            others[2 * std::size_t(slot)] = t[i + (k + 1) % 3];
            others[2 * std::size_t(slot) + 1] = t[i + (k + 2) % 3];
        }
    return g;
}

/// Neighbours of each vertex across the triangles' edges, ascending, each once, row by row in
/// parallel, from the triangles' other corners (`others` of vertex_triangles, sorted in place).
/// Around a vertex of a closed oriented mesh each neighbour is the corner after it in one triangle
/// and the one before it in another: the row's 2k corners are sorted (a short insertion sort)
/// and taken once.
Rows vertex_neighbours(const Rows& tri, std::vector<std::uint32_t>& others) {
    const std::size_t nv = tri.offset.size() - 1;
    std::vector<std::uint32_t> kept(nv);
    for_vertices(nv, [&](std::size_t v) {
        std::uint32_t* row = others.data() + 2 * std::size_t(tri.offset[v]);
        const std::uint32_t n = 2 * (tri.offset[v + 1] - tri.offset[v]);
        for (std::uint32_t j = 1; j < n; ++j) {
            const std::uint32_t u = row[j];
            std::uint32_t i = j;
            for (; i > 0 && row[i - 1] > u; --i) row[i] = row[i - 1];
            row[i] = u;
        }
        std::uint32_t m = 0;
        for (std::uint32_t i = 0; i < n; ++i)
            if (row[i] != v && (m == 0 || row[m - 1] != row[i])) row[m++] = row[i];
        kept[v] = m;
    });
    Rows g;
    g.offset.assign(nv + 1, 0);
    for (std::size_t v = 0; v < nv; ++v) g.offset[v + 1] = g.offset[v] + kept[v];
    g.item.resize(g.offset[nv]);
    for_vertices(nv, [&](std::size_t v) {
        std::copy_n(others.begin() + 2 * std::ptrdiff_t(tri.offset[v]), kept[v], g.item.begin() + g.offset[v]);
    });
    return g;
}

glm::dvec3 face_cross(const std::vector<glm::dvec3>& p, const std::uint32_t* c) {
    return glm::cross(p[c[1]] - p[c[0]], p[c[2]] - p[c[0]]);
}

}  // namespace

std::vector<float> smoothing_weights(const std::vector<float>& positions, const ParticleGrid& grid, float r, float R) {
    const std::size_t nv = positions.size() / 3;
    std::vector<float> w(nv, 0.0f);
    if (nv == 0 || grid.size() == 0) return w;
    const SumOrder order(positions, grid.size(), R);
    const double R2 = double(R) * R;
    // The kernel sum at a vertex on the flat surface of particles at rest spacing 2r: half the
    // interior's, rho * 4 pi R^3 * 16/315 (the integral of (1 - d^2/R^2)^3 over the ball), less
    // the layer of about r between the surface and the outer particles (a factor of about 0.7).
    const double flat = 0.5 * 0.7 * (4.0 * kPi * 16.0 / 315.0) * std::pow(double(R) / (2.0 * r), 3.0);
    // Share of the way from kWeightLow to kWeightHigh; every step rounds monotonically, so it never
    // decreases as the sum grows.
    const auto ramp = [&](double sum) { return std::clamp((sum / flat - kWeightLow) / (kWeightHigh - kWeightLow), 0.0, 1.0); };
    struct Term {
        std::uint64_t key;
        std::uint32_t j;
        double k;
        bool operator<(const Term& o) const { return key != o.key ? key < o.key : j < o.j; }
    };
    // A partial sum at or above `full` already gives the ramp 1 at SumOrder's whole sum: its terms
    // are a part of that sum's (all >= 0), so that sum is at least the partial one times
    // (1 - count 2^-50), count <= grid.size(), and the ramp never decreases. Most vertices of a
    // large frame stop there, about halfway through their candidates.
    const double below = 1.0 - 2.0 * double(grid.size() + 1) * 0x1p-50;
    double full = kWeightHigh * flat * (1.0 + 0x1p-20);
    if (ramp(full * below) != 1.0) full = INFINITY;  // never seen: then every sum runs to its end
    tbb::enumerable_thread_specific<std::vector<Term>> scratch;
    for_vertices(nv, [&](std::size_t v) {
        const glm::vec3 pf(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
        const glm::dvec3 p(pf);
        const glm::ivec3 c = order.of_vertex(p);
        // The terms (1 - d^2/R^2)^3 >= 0 summed in the grid's order (rows nearest first: the
        // partial sum reaches `full` early). Any order's rounded sum lies
        // within (n - 1) 2^-53 (1 + small) of the exact sum, so SumOrder's sum lies within
        // n 2^-50 sum of this one. Where the ramp is the same at both ends of that interval (the
        // bulk's surface at 1 and splashes at 0: all but a few vertices of a large frame), it is
        // the same at SumOrder's sum too, and the terms need no sorting.
        double sum = 0.0;
        std::size_t n = 0;
        std::uint64_t key;
        const bool check = !order.scans_all();
        grid.for_each_candidate(pf, R, [&](std::uint32_t, glm::vec3 xj) {
            const glm::dvec3 d = p - glm::dvec3(xj);
            const double d2 = glm::dot(d, d);
            if (!(d2 < R2) || (check && !order.key(c, glm::dvec3(xj), key))) return false;
            const double x = 1.0 - d2 / R2;
            sum += x * x * x;
            ++n;
            return sum >= full;
        });
        const double slack = 2.0 * double(n + 1) * 0x1p-50 * sum;
        double x = sum >= full ? 1.0 : ramp(sum);
        if (sum < full && ramp(sum - slack) != ramp(sum + slack)) {
            std::vector<Term>& terms = scratch.local();
            terms.clear();
            grid.for_each_candidate(pf, R, [&](std::uint32_t j, glm::vec3 xj) {
                const glm::dvec3 d = p - glm::dvec3(xj);
                const double d2 = glm::dot(d, d);
                if (!(d2 < R2) || !order.key(c, glm::dvec3(xj), key)) return;
                const double y = 1.0 - d2 / R2;
                terms.push_back({key, j, y * y * y});
            });
            std::sort(terms.begin(), terms.end());
            sum = 0.0;
            for (const Term& t : terms) sum += t.k;
            x = ramp(sum);
        }
        w[v] = float(x * x * (3.0 - 2.0 * x));
    });
    return w;
}

SmoothingReport smooth_mesh(Mesh& mesh, const std::vector<float>& weights, const SmoothingSettings& settings) {
    SmoothingReport report;
    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    if (weights.size() != nv) throw Error("smoothing: " + std::to_string(weights.size()) + " weights for " + std::to_string(nv) + " vertices");
    if (nv == 0 || settings.iterations <= 0) return report;
    // The components and their volumes (serial sweeps) beside the triangle rows (serial too).
    Rows tri;
    std::vector<std::uint32_t> others;
    MeshComponents comp;
    std::vector<double> volume0;
    run_beside(
        [&] {
            comp = mesh_components(mesh);
            volume0 = component_volumes(mesh, comp);
        },
        [&] { tri = vertex_triangles(mesh, others); });
    const Rows nbr = vertex_neighbours(tri, others);
    std::vector<std::uint32_t>().swap(others);
    std::vector<float> w(nv);  // small components keep their vertices
    std::vector<glm::dvec3> p(nv), q(nv);
    for_vertices(nv, [&](std::size_t v) {
        w[v] = std::fabs(volume0[comp.of_vertex[v]]) < settings.min_volume ? 0.0f : weights[v];
        p[v] = {mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]};
    });
    const std::uint32_t* corners = mesh.triangles.data();
    std::vector<glm::dvec3> n0(nt);  // orientation before smoothing: no triangle may turn against it
    tbb::parallel_for(std::size_t(0), nt, [&](std::size_t t) { n0[t] = face_cross(p, corners + 3 * t); });
    std::vector<std::uint8_t> bad(nt);

    // Takes back the moves (p -> q) at every corner of a triangle that q turns over, until none is
    // left. After the first pass over all triangles only those around the vertices just taken back
    // can change; each round's set of vertices is taken back as a whole, so the result does not
    // depend on any order (p itself turns nothing over, so this ends).
    std::vector<std::uint8_t> mark(std::max(nv, nt), 0);
    auto turned = [&](std::size_t t) { return glm::dot(face_cross(q, corners + 3 * t), n0[t]) <= 0.0 && n0[t] != glm::dvec3(0.0); };
    const std::uint8_t* moving = nullptr;  // where set: only components k with moving[k] moved
    auto guard = [&] {
        tbb::parallel_for(std::size_t(0), nt, [&](std::size_t t) {
            bad[t] = (!moving || moving[comp.of_vertex[corners[3 * t]]]) && turned(t);
        });
        std::vector<std::uint32_t> bad_list, undo, check;
        for (std::size_t t = 0; t < nt; ++t)
            if (bad[t]) bad_list.push_back(std::uint32_t(t));
        while (!bad_list.empty()) {
            undo.clear();
            for (std::uint32_t t : bad_list)
                for (int k = 0; k < 3; ++k) {
                    const std::uint32_t v = corners[3 * std::size_t(t) + k];
                    if (q[v] != p[v] && !mark[v]) {
                        mark[v] = 1;
                        undo.push_back(v);
                    }
                }
            for (std::uint32_t v : undo) {
                q[v] = p[v];
                mark[v] = 0;
            }
            report.reverted_moves += undo.size();
            check.clear();
            for (std::uint32_t v : undo)
                for (std::uint32_t k = tri.offset[v]; k < tri.offset[v + 1]; ++k)
                    if (!mark[tri.item[k]]) {
                        mark[tri.item[k]] = 1;
                        check.push_back(tri.item[k]);
                    }
            bad_list.clear();
            for (std::uint32_t t : check) {
                mark[t] = 0;
                if (turned(t)) bad_list.push_back(t);
            }
        }
    };
    // Accepts the moves p -> q less those guard() takes back.
    auto accept = [&] {
        guard();
        std::swap(p, q);
    };
    // Accepts the moves made since `from`, checked as one: p becomes the guarded positions.
    auto accept_since = [&](std::vector<glm::dvec3>& from) {
        q.swap(p);
        p.swap(from);
        accept();
    };
    std::vector<glm::dvec3> normal(nv, glm::dvec3(0.0));
    // Each triangle's cross product, taken once per triangle (a vertex's sweep would take each
    // three times, gathering its corners at random), of the triangles in the components where
    // `only` is set (all: nullptr); `also(t)` runs after each.
    std::vector<glm::dvec3> cross(nt);
    auto take_crosses = [&](const std::uint8_t* only, auto&& also) {
        tbb::parallel_for(std::size_t(0), nt, [&](std::size_t t) {
            if (only && !only[comp.of_vertex[corners[3 * t]]]) return;
            cross[t] = face_cross(p, corners + 3 * t);
            also(t);
        });
    };
    // The sum of v's triangles' cross products, in row order.
    auto cross_sum = [&](std::size_t v) {
        glm::dvec3 n(0.0);
        for (std::uint32_t k = tri.offset[v]; k < tri.offset[v + 1]; ++k) n += cross[tri.item[k]];
        return n;
    };
    auto vertex_normals = [&] {
        take_crosses(nullptr, [](std::size_t) {});
        for_vertices(nv, [&](std::size_t v) {
            const glm::dvec3 n = cross_sum(v);
            const double l = glm::length(n);
            normal[v] = l > 0 ? n / l : glm::dvec3(0.0);
        });
    };
    // p <- p + w step(v, b, e) at each vertex with a positive weight and items b..e of `rows`.
    auto weighted_move = [&](const Rows& rows, auto&& step) {
        for_vertices(nv, [&](std::size_t v) {
            const std::uint32_t b = rows.offset[v], e = rows.offset[v + 1];
            q[v] = b == e || w[v] <= 0.0f ? p[v] : p[v] + double(w[v]) * step(v, b, e);
        });
        std::swap(p, q);
    };
    auto neighbour_mean = [&](std::uint32_t b, std::uint32_t e) {
        glm::dvec3 mean(0.0);
        for (std::uint32_t k = b; k < e; ++k) mean += p[nbr.item[k]];
        return mean / double(e - b);
    };
    auto laplacian_step = [&](double factor) {
        weighted_move(nbr, [&](std::size_t v, std::uint32_t b, std::uint32_t e) { return factor * (neighbour_mean(b, e) - p[v]); });
    };
    // Restores each component's volume (SmoothingSettings::keep_volume); its arrays are made once
    // for all the restorations of a long run.
    std::vector<double> term, gradient;
    auto restore_volumes = [&] {
        // Newton steps on the offset d of each component along its unit vertex normals n_v: the
        // volume's derivative is sum_v n_v . dV/dp_v, and dV/dp_v = (sum of v's triangles' cross
        // products) / 6, whose direction n_v is: the slope is the sum of their lengths / 6.
        // A step is bounded by a quarter of the component's volume over its area (a twelfth of a
        // ball's radius), so that a tiny component shrunk by the steps is regrown gradually.
        // One sweep over the triangles per step takes their cross products and volume terms
        // (summed per component in triangle order), one over the vertices their normals. A
        // component stops once its volume is within 1e-9 of the one before smoothing (under the
        // rounding of the float positions written at the end, about 1e-7): later steps sweep only
        // the components still moving, a cavity shrunk by the Laplacian steps, say.
        term.resize(nt);
        gradient.resize(nv);
        std::vector<std::uint8_t> active(comp.count);
        for (std::size_t k = 0; k < comp.count; ++k) active[k] = std::fabs(volume0[k]) >= settings.min_volume;
        moving = active.data();
        for (int pass = 0; pass < 8; ++pass) {
            std::vector<double> volume(comp.count, 0.0), slope(comp.count, 0.0);
            take_crosses(active.data(), [&](std::size_t t) { term[t] = glm::dot(p[corners[3 * t]], cross[t]) / 6.0; });
            for_vertices(nv, [&](std::size_t v) {
                if (!active[comp.of_vertex[v]]) return;
                const glm::dvec3 n = cross_sum(v);
                gradient[v] = glm::length(n) / 6.0;
                normal[v] = gradient[v] > 0 ? n / (6.0 * gradient[v]) : glm::dvec3(0.0);
            });
            for (std::size_t t = 0; t < nt; ++t)
                if (const std::uint32_t k = comp.of_vertex[corners[3 * t]]; active[k]) volume[k] += term[t];
            bool any = false;
            for (std::size_t k = 0; k < comp.count; ++k) {
                if (active[k] && std::fabs(volume0[k] - volume[k]) <= 1e-9 * std::fabs(volume0[k])) active[k] = 0;
                any = any || active[k];
            }
            if (!any) break;
            for (std::size_t v = 0; v < nv; ++v)
                if (const std::uint32_t k = comp.of_vertex[v]; active[k]) slope[k] += gradient[v];
            // volume[] is taken about the origin, volume0 about each component's first vertex:
            // equal for a closed component up to rounding.
            for_vertices(nv, [&](std::size_t v) {
                const std::uint32_t k = comp.of_vertex[v];
                if (!active[k]) {
                    q[v] = p[v];
                    return;
                }
                const double limit = 0.25 * std::fabs(volume0[k]) / std::max(slope[k], 1e-300);
                const double d = slope[k] > 0 ? std::clamp((volume0[k] - volume[k]) / slope[k], -limit, limit) : 0.0;
                q[v] = p[v] + d * normal[v];
            });
            accept();
        }
        moving = nullptr;
    };
    // Checked for turned triangles at the end, against the positions before the steps. A long
    // run restores the volumes every kVolumeEvery steps as it goes: the Laplacian steps shrink a
    // body along its curvature, a droplet of radius 8r to a fraction of its volume in 100 steps,
    // and past that the give-back and the volume correction at the end regrew a crumpled mesh
    // (with 100 steps that droplet came out at a tenth of its volume, twice as wide).
    std::vector<glm::dvec3> before = p;
    for (int it = 0; it < settings.iterations; ++it) {
        laplacian_step(settings.lambda);
        if (settings.mu != 0.0) laplacian_step(settings.mu);
        if (settings.keep_volume && (it + 1) % kVolumeEvery == 0 && it + 1 < settings.iterations) {
            accept_since(before);
            restore_volumes();
            before = p;
        }
    }
    accept_since(before);

    // Two fields are averaged over a wide neighbourhood, in the same rounds of averaging over the
    // 1-ring (a reach of about sqrt(rounds) edges): the normal part of each vertex's whole move,
    // and the vertex normals.
    // - Laplacian steps shrink a surface by an amount that follows its curvature, slowly along
    //   it; the bumps they remove change from vertex to vertex. So the averaged normal part of the
    //   moves is the shrink: given back along the normals, it keeps the shape (a torus' tube stays
    //   round) while the bumps stay removed.
    // - The Laplacian steps leave the particles' outer layer's long bumps (several particle
    //   spacings wide), which a wider Laplacian would only remove by shrinking and distorting the
    //   body. So the vertices follow the averaged normals instead: each triangle takes the mean of
    //   its corners' averaged normals, and each vertex moves to the mean of its projections onto
    //   the planes through its triangles' centroids across those normals (the vertex update of
    //   Sun, Rosin, Martin and Langbein, "Fast and effective feature-preserving mesh denoising",
    //   TVCG 2007), weighted as in the Laplacian steps.
    vertex_normals();
    // The averaged fields are floats: their rounding (2^-24 of a normal, of a shrink of a tenth
    // of r) lies far under what they steer. Each vertex's averaged normal (xyz) and shrink (w)
    // share one vec4, so that a round reads one 16-byte value per neighbour. The normals are
    // averaged as vectors and normalised only where a triangle takes them (renormalising every
    // round gave the same metrics on the analytic bodies, at a square root and a division per
    // vertex and round).
    std::vector<glm::vec4> field(nv), field_next(nv);
    for_vertices(nv, [&](std::size_t v) {
        const glm::dvec3 o(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
        field[v] = glm::vec4(glm::vec3(normal[v]), float(glm::dot(p[v] - o, normal[v])));
    });
    const bool follow_normals = settings.normal_passes > 0 && settings.update_passes > 0;
    for (int pass = 0; pass < std::max(settings.shrink_passes, follow_normals ? settings.normal_passes : 0); ++pass) {
        const bool average_shrink = pass < settings.shrink_passes, average_normals = follow_normals && pass < settings.normal_passes;
        for_vertices(nv, [&](std::size_t v) {
            glm::vec4 sum = field[v];
            for (std::uint32_t k = nbr.offset[v]; k < nbr.offset[v + 1]; ++k) sum += field[nbr.item[k]];
            const glm::vec4 mean = sum * (1.0f / float(nbr.offset[v + 1] - nbr.offset[v] + 1));
            field_next[v] = glm::vec4(average_normals ? glm::vec3(mean) : glm::vec3(field[v]), average_shrink ? mean.w : field[v].w);
        });
        std::swap(field, field_next);
    }
    if (settings.shrink_passes > 0) {
        for_vertices(nv, [&](std::size_t v) { q[v] = p[v] - (double(field[v].w) * double(w[v])) * normal[v]; });
        accept();
    }
    if (follow_normals) {
        // Each triangle's plane: its normal and its offset along it (through the centroid).
        std::vector<glm::vec3> face_normal(nt);
        std::vector<double> offset(nt);
        tbb::parallel_for(std::size_t(0), nt, [&](std::size_t t) {
            const std::uint32_t* c = corners + 3 * t;
            const glm::vec3 sum = glm::vec3(field[c[0]]) + glm::vec3(field[c[1]]) + glm::vec3(field[c[2]]);
            const float l = glm::length(sum);
            face_normal[t] = l > 0 ? sum / l : glm::vec3(0.0f);
        });
        // Moves this small rarely turn a triangle over: they are checked once, at the end of the
        // update and tangential steps, against the positions before them.
        before = p;
        for (int pass = 0; pass < settings.update_passes; ++pass) {
            tbb::parallel_for(std::size_t(0), nt, [&](std::size_t t) {
                const std::uint32_t* c = corners + 3 * t;
                offset[t] = glm::dot(glm::dvec3(face_normal[t]), (p[c[0]] + p[c[1]] + p[c[2]]) / 3.0);
            });
            weighted_move(tri, [&](std::size_t v, std::uint32_t b, std::uint32_t e) {
                glm::dvec3 move(0.0);
                for (std::uint32_t k = b; k < e; ++k) {
                    const std::uint32_t t = tri.item[k];
                    const glm::dvec3 n(face_normal[t]);
                    move += n * (offset[t] - glm::dot(n, p[v]));
                }
                return settings.update_step * move / double(e - b);
            });
        }
        // The update moves vertices across the surface only as the normals pull them, which
        // narrows some triangles: steps towards the neighbours' mean within the tangent plane
        // even them out without moving the surface.
        for (int pass = 0; pass < settings.tangential_passes; ++pass) {
            vertex_normals();
            weighted_move(nbr, [&](std::size_t v, std::uint32_t b, std::uint32_t e) {
                const glm::dvec3 d = neighbour_mean(b, e) - p[v];
                return d - normal[v] * glm::dot(d, normal[v]);
            });
        }
        accept_since(before);
    }
    if (settings.keep_volume) restore_volumes();
    for_vertices(nv, [&](std::size_t v) {
        for (int a = 0; a < 3; ++a) mesh.positions[3 * v + a] = float(p[v][a]);
    });
    return report;
}

}  // namespace trilevel
