// One reader per particle file format; `data` is the whole file. Each returns x, y, z per
// particle (and the attributes asked for) and throws Error naming `path` and, where possible,
// the line or byte offset and what was expected.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel::io {

/// What read_particles asks of a format reader.
struct ReadRequest {
    const std::string& path;
    const std::string& data;              ///< the whole file
    std::vector<std::string> attributes;  ///< point attributes to read, no duplicates
    /// Store NaN/Inf coordinates (read_particles then drops those particles) instead of failing.
    bool keep_invalid = false;
    /// The string `data` refers to, when nothing reads it after the reader: a reader may then empty
    /// it once it holds everything it needs in another form (read_bgeo, once a gzip'd file is
    /// inflated: the file, the inflated data and the positions alive at once were a large run's
    /// peak). Null for data the caller keeps (the fuzz targets).
    std::string* releasable = nullptr;
};

ParticleSet read_vtk(const ReadRequest& request);
ParticleSet read_vtu(const ReadRequest& request);
ParticleSet read_bgeo(const ReadRequest& request);
ParticleSet read_ply(const ReadRequest& request);
ParticleSet read_xyz(const ReadRequest& request);

/// read_particles on a file already in memory: `ext` (vtk, vtu, bgeo, ply or xyz) picks the reader,
/// `path` names the file in messages. Used by read_particles and the fuzz targets (fuzz/), so that
/// these also cover repeated attribute names and dropping NaN/Inf particles.
ParticleSet read_particles_from_memory(const std::string& ext, const std::string& path, const std::string& data,
                                       const ReadOptions& options);

/// read_mesh on a file already in memory: `ext` (ply, obj or vtk) picks the reader, `path` names
/// the file in messages. Used by read_mesh and the fuzz target (fuzz/).
Mesh read_mesh_from_memory(const std::string& ext, const std::string& path, const std::string& data);

/// Legacy VTK POLYDATA as write_mesh writes it: POINTS, POLYGONS, optional POINT_DATA level.
Mesh read_vtk_mesh(const std::string& path, const std::string& data);

/// Gathers the requested attributes while a reader walks the file's point arrays: the reader
/// asks wanted(name) for each array it meets (which also notes the name for the error listing
/// what the file has) and appends the values of the wanted ones, piece by piece.
class AttributeSink {
public:
    explicit AttributeSink(const ReadRequest& request);

    /// Index of `name` among the requested attributes, or -1 (then the reader skips the array):
    /// also -1 for a second array of that name in the same piece (the first one counts).
    int wanted(std::string_view name);

    /// Whether `name` is requested (without noting it as a name the file has).
    bool requested(std::string_view name) const {
        for (const auto& a : attrs_) if (a.name == name) return true;
        return false;
    }

    /// Starts the next VTU piece: each requested attribute is read once per piece.
    void next_piece() { taken_.assign(attrs_.size(), false); }

    /// Appends values of requested attribute `index`; `where` locates the array for errors
    /// (components other than 1 or 3, or differing between pieces).
    void append(int index, int components, const std::vector<float>& values, const std::string& where);

    /// The attributes in request order; Error for a name never met (listing the names the file
    /// has) or one that does not cover all `particles` (e.g. missing from one VTU piece).
    std::vector<ParticleAttribute> finish(std::size_t particles);

private:
    const std::string& path_;
    std::vector<ParticleAttribute> attrs_;
    std::vector<bool> seen_, taken_;
    std::vector<std::string> available_;
};

}  // namespace trilevel::io
