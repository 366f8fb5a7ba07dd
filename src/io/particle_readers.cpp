// read_particles: dispatch by extension, plus the raw .xyz reader.
#include "io/io_common.hpp"
#include "io/particle_formats.hpp"
#include "trilevel/io.hpp"

namespace trilevel {

namespace io {
std::vector<float> read_xyz_points(const std::string& path, const std::string& data) {
    if (data.size() % 12 != 0)
        fail(path, "size " + std::to_string(data.size()) + " bytes is not a multiple of 12 (raw float32 x, y, z triplets)");
    return convert_coords(path, data.data(), data.size() / 4, Scalar::F32, false);
}
}  // namespace io

namespace {
using Reader = std::vector<float> (*)(const std::string&, const std::string&);

Reader particle_reader(const std::string& ext, const std::string& path) {
    using namespace io;
    if (ext == "vtk") return read_vtk_points;
    if (ext == "vtu") return read_vtu_points;
    if (ext == "bgeo") return read_bgeo_points;
    if (ext == "ply") return read_ply_points;
    if (ext == "xyz") return read_xyz_points;
    fail(path, "unknown particle file extension '" + ext + "', expected .vtk, .vtu, .bgeo, .ply or .xyz");
}
}  // namespace

ParticleSet io::read_particles_from_memory(const std::string& ext, const std::string& path, const std::string& data,
                                          const ReadOptions& options) {
    (void)options;  // attributes and drop_invalid: see issue 5/6 work in progress
    ParticleSet set;
    set.positions = particle_reader(ext, path)(path, data);
    return set;
}

ParticleSet read_particles(const std::string& path, const ReadOptions& options) {
    using namespace io;
    require_file(path);  // a missing file is reported as such, whatever its name
    const std::string ext = extension_of(path);
    particle_reader(ext, path);  // an unknown extension is reported before the file is read
    return read_particles_from_memory(ext, path, read_file(path), options);
}

}  // namespace trilevel
