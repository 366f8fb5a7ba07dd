// read_particles: dispatch by extension, the attribute sink shared by the readers, dropping of
// NaN/Inf particles, plus the raw .xyz reader.
#include <algorithm>
#include <cmath>

#include "io/io_common.hpp"
#include "io/particle_formats.hpp"
#include "trilevel/io.hpp"

namespace trilevel {

namespace io {

ParticleSet read_xyz(const ReadRequest& r) {
    if (r.data.size() % 12 != 0)
        fail(r.path, "size " + std::to_string(r.data.size()) + " bytes is not a multiple of 12 (raw float32 x, y, z triplets)");
    AttributeSink sink(r);  // raw triplets carry no attributes: any requested one is an error
    ParticleSet set;
    set.positions = convert_coords(r.path, r.data.data(), r.data.size() / 4, Scalar::F32, false, !r.keep_invalid, {0, {}});
    set.attributes = sink.finish(set.size());
    return set;
}

AttributeSink::AttributeSink(const ReadRequest& r)
    : path_(r.path), seen_(r.attributes.size(), false), taken_(r.attributes.size(), false) {
    for (const auto& name : r.attributes) attrs_.push_back({name, 0, {}});
}

int AttributeSink::wanted(std::string_view name) {
    if (std::find(available_.begin(), available_.end(), name) == available_.end()) available_.emplace_back(name);
    for (std::size_t i = 0; i < attrs_.size(); ++i)
        if (attrs_[i].name == name) {
            if (taken_[i]) return -1;
            taken_[i] = true;
            return static_cast<int>(i);
        }
    return -1;
}

void AttributeSink::append(int index, int components, const std::vector<float>& values, const std::string& where) {
    ParticleAttribute& a = attrs_[static_cast<std::size_t>(index)];
    const std::string at = where.empty() ? "" : where + ": ";
    if (components != 1 && components != 3)
        fail(path_, at + "attribute '" + a.name + "' has " + std::to_string(components) + " components, expected 1 or 3");
    if (seen_[index] && a.components != components)
        fail(path_, at + "attribute '" + a.name + "' has " + std::to_string(components) + " components here, " +
                        std::to_string(a.components) + " before");
    a.components = components;
    seen_[index] = true;
    a.values.insert(a.values.end(), values.begin(), values.end());
}

std::vector<ParticleAttribute> AttributeSink::finish(std::size_t particles) {
    for (std::size_t i = 0; i < attrs_.size(); ++i) {
        if (!seen_[i]) missing_attribute(path_, attrs_[i].name, available_);
        const std::size_t expected = particles * static_cast<std::size_t>(attrs_[i].components);
        if (attrs_[i].values.size() != expected)
            fail(path_, "attribute '" + attrs_[i].name + "' holds " + std::to_string(attrs_[i].values.size()) +
                            " values, expected " + std::to_string(expected) + " (" + std::to_string(particles) +
                            " particles); is it missing from a piece?");
    }
    return std::move(attrs_);
}

namespace {

/// Removes the particles with a NaN/Inf coordinate, and their attribute values, in place.
void drop_invalid(const std::string& path, ParticleSet& set) {
    const std::size_t n = set.size();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const float* p = &set.positions[3 * i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
        if (kept != i) {
            std::copy(p, p + 3, &set.positions[3 * kept]);
            for (auto& a : set.attributes) {
                const std::size_t c = static_cast<std::size_t>(a.components);
                std::copy(&a.values[c * i], &a.values[c * i] + c, &a.values[c * kept]);
            }
        }
        ++kept;
    }
    set.positions.resize(3 * kept);
    for (auto& a : set.attributes) a.values.resize(static_cast<std::size_t>(a.components) * kept);
    set.dropped_invalid = n - kept;
    if (n > 0 && kept == 0) fail(path, "no valid particles: all " + std::to_string(n) + " have NaN/Inf coordinates");
}

using Reader = ParticleSet (*)(const ReadRequest&);

/// The reader of a particle file extension, or nullptr for an unknown one.
Reader particle_reader(const std::string& ext) {
    if (ext == "vtk") return read_vtk;
    if (ext == "vtu") return read_vtu;
    if (ext == "bgeo") return read_bgeo;
    if (ext == "ply") return read_ply;
    if (ext == "xyz") return read_xyz;
    return nullptr;
}

[[noreturn]] void unknown_extension(const std::string& path, const std::string& ext) {
    fail(path, "unknown particle file extension '" + ext + "', expected .vtk, .vtu, .bgeo, .ply or .xyz");
}

}  // namespace

namespace {

ParticleSet read_from_memory(const std::string& ext, const std::string& path, const std::string& data,
                             std::string* releasable, const ReadOptions& options) {
    const Reader reader = particle_reader(ext);
    if (!reader) unknown_extension(path, ext);
    ReadRequest request{path, data, {}, options.drop_invalid, releasable};
    for (const auto& name : options.attributes)  // a name asked twice is read once
        if (std::find(request.attributes.begin(), request.attributes.end(), name) == request.attributes.end())
            request.attributes.push_back(name);
    ParticleSet set = reader(request);
    if (options.drop_invalid) drop_invalid(path, set);
    return set;
}

}  // namespace

ParticleSet read_particles_from_memory(const std::string& ext, const std::string& path, const std::string& data,
                                       const ReadOptions& options) {
    return read_from_memory(ext, path, data, nullptr, options);
}

}  // namespace io

ParticleSet read_particles(const std::string& path, const ReadOptions& options) {
    io::require_file(path);  // a missing file is reported as such, whatever its name
    const std::string ext = io::extension_of(path);
    if (!io::particle_reader(ext)) io::unknown_extension(path, ext);  // before reading the whole file
    std::string data = io::read_file(path);
    return io::read_from_memory(ext, path, data, &data, options);
}

}  // namespace trilevel
