// write_particles: .xyz (raw float32 LE), .ply (binary LE), .vtk (legacy BINARY, big-endian).
#include "io/io_common.hpp"
#include "trilevel/io.hpp"

namespace trilevel {
namespace io {

/// Writes floats in the given byte order through a chunked conversion buffer.
void write_floats(AtomicWriter& out, const float* v, std::size_t count, bool big_endian) {
    if (!big_endian) { out.write(v, count * sizeof(float)); return; }
    std::vector<char> chunk(std::size_t(1) << 20);
    for (std::size_t i = 0; i < count;) {
        const std::size_t n = std::min(count - i, chunk.size() / 4);
        for (std::size_t k = 0; k < n; ++k) store<float>(chunk.data() + 4 * k, v[i + k], true);
        out.write(chunk.data(), 4 * n);
        i += n;
    }
}

namespace {

void write_vtk_particles(AtomicWriter& out, const ParticleSet& p) {
    const std::size_t n = p.size();
    out.write("# vtk DataFile Version 4.2\nparticles\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS " + std::to_string(n) + " float\n");
    write_floats(out, p.positions.data(), p.positions.size(), true);
    if (n > 0x3fffffff) return;  // vertex cells would overflow int32 indices: points only
    out.write("\nCELLS " + std::to_string(n) + " " + std::to_string(2 * n) + "\n");
    std::vector<char> chunk(std::size_t(1) << 20);
    for (std::size_t i = 0; i < n;) {  // one VTK_VERTEX cell per particle, as SPlisHSPlasH writes
        const std::size_t m = std::min(n - i, chunk.size() / 8);
        for (std::size_t k = 0; k < m; ++k) {
            store<std::int32_t>(chunk.data() + 8 * k, 1, true);
            store<std::int32_t>(chunk.data() + 8 * k + 4, static_cast<std::int32_t>(i + k), true);
        }
        out.write(chunk.data(), 8 * m);
        i += m;
    }
    out.write("\nCELL_TYPES " + std::to_string(n) + "\n");
    std::vector<char> one(4);
    store<std::int32_t>(one.data(), 1, true);
    for (std::size_t i = 0; i < n; ++i) out.write(one.data(), 4);
    out.write("\n");
}

}  // namespace
}  // namespace io

void write_particles(const std::string& path, const ParticleSet& particles) {
    using namespace io;
    const std::string ext = extension_of(path);
    if (ext != "xyz" && ext != "ply" && ext != "vtk")
        fail(path, "unknown particle output extension '" + ext + "', expected .xyz, .ply or .vtk");
    if (particles.positions.size() % 3 != 0) fail(path, "particle positions are not x, y, z triplets");
    check_finite(path, particles.positions);
    AtomicWriter out(path);
    if (ext == "xyz") {
        write_floats(out, particles.positions.data(), particles.positions.size(), false);
    } else if (ext == "ply") {
        out.write("ply\nformat binary_little_endian 1.0\ncomment trilevel particles\nelement vertex " +
                  std::to_string(particles.size()) + "\nproperty float x\nproperty float y\nproperty float z\nend_header\n");
        write_floats(out, particles.positions.data(), particles.positions.size(), false);
    } else {
        write_vtk_particles(out, particles);
    }
    out.commit();
}

}  // namespace trilevel
