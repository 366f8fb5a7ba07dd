// Boxes of Params; see particle_box.hpp.
#include "particle_box.hpp"

#include <cmath>
#include <sstream>

namespace trilevel {

std::string box_text(const Box& b) {
    std::ostringstream s;
    s.precision(9);
    s << "[" << b.min[0] << ", " << b.max[0] << "] x [" << b.min[1] << ", " << b.max[1] << "] x [" << b.min[2] << ", "
      << b.max[2] << "]";
    return s.str();
}

void validate_box(const Box& b, const std::string& what) {
    for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(b.min[k]) || !std::isfinite(b.max[k]))
            throw Error(what + " " + box_text(b) + " must have finite bounds");
        if (!(b.min[k] < b.max[k]))
            throw Error(what + " " + box_text(b) + " is empty: its minimum " + "xyz"[k] + " must be below its maximum");
    }
}

std::size_t keep_particles_in_box(std::vector<float>& xyz, std::vector<ParticleAttribute>& attributes, const Box& b) {
    const std::size_t n = xyz.size() / 3;
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const float* p = &xyz[3 * i];
        bool inside = true;
        for (int k = 0; k < 3; ++k) inside = inside && p[k] >= b.min[k] && p[k] <= b.max[k];
        if (!inside) continue;
        for (int k = 0; k < 3; ++k) xyz[3 * kept + k] = xyz[3 * i + k];
        for (auto& a : attributes) {
            const std::size_t c = std::size_t(a.components);
            for (std::size_t k = 0; k < c; ++k) a.values[c * kept + k] = a.values[c * i + k];
        }
        ++kept;
    }
    if (kept == 0)
        throw Error("no particles inside the particle box " + box_text(b) + ": all " + std::to_string(n) + " lie outside");
    xyz.resize(3 * kept);
    for (auto& a : attributes) a.values.resize(std::size_t(a.components) * kept);
    return kept;
}

}  // namespace trilevel
