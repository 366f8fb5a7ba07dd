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

ParticleSet read_particles(const std::string& path, const ReadOptions& options) {
    (void)options;  // attributes and drop_invalid: see issue 5/6 work in progress
    using namespace io;
    require_file(path);  // a missing file is reported as such, whatever its name
    const std::string ext = extension_of(path);
    using Reader = std::vector<float> (*)(const std::string&, const std::string&);
    Reader reader = nullptr;
    if (ext == "vtk") reader = read_vtk_points;
    else if (ext == "vtu") reader = read_vtu_points;
    else if (ext == "bgeo") reader = read_bgeo_points;
    else if (ext == "ply") reader = read_ply_points;
    else if (ext == "xyz") reader = read_xyz_points;
    else fail(path, "unknown particle file extension '" + ext + "', expected .vtk, .vtu, .bgeo, .ply or .xyz");
    const std::string data = read_file(path);
    ParticleSet set;
    set.positions = reader(path, data);
    return set;
}

}  // namespace trilevel
