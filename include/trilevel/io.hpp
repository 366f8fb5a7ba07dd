// Particle readers, mesh writers and the scene generator of trilevel.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// Particle positions read from a file, x, y, z per particle, in file order.
struct ParticleSet {
    std::vector<float> positions;                ///< x, y, z per particle, world units (as in the file)
    std::vector<ParticleAttribute> attributes;  ///< only those asked for in ReadOptions::attributes
                                                ///< (ParticleAttribute: trilevel.hpp)
    std::size_t dropped_invalid = 0;            ///< particles dropped by ReadOptions::drop_invalid
    std::size_t size() const { return positions.size() / 3; }  ///< number of particles
};

/// What read_particles reads besides the positions.
struct ReadOptions {
    /// Attributes to read as well; a name the file lacks is an Error listing the names it has.
    /// VTK: POINT_DATA SCALARS/VECTORS/NORMALS and FIELD arrays of one tuple per point; VTU:
    /// PointData arrays; BGEO: float, vector and int point attributes; PLY: a vertex property
    /// `name`, or the triplet name_x/_y/_z (or namex/y/z). 1 or 3 components, any numeric type
    /// (converted to float, values kept as stored: NaN is not checked). ParticleSet::attributes
    /// follows this order; a name given twice is read once.
    std::vector<std::string> attributes;
    /// Drop particles with a NaN/Inf coordinate (counted in ParticleSet::dropped_invalid)
    /// instead of failing.
    bool drop_invalid = false;
};

/// Reads particles by extension: .vtk (legacy, ASCII/BINARY), .vtu, .bgeo (gzip'd or not), .ply, .xyz
/// (little-endian float32 triplets). Throws Error naming the file and what is wrong (also for a
/// NaN/Inf coordinate unless options.drop_invalid).
ParticleSet read_particles(const std::string& path, const ReadOptions& options = {});

/// Writes the positions of `particles` by extension: .xyz, .ply (binary), .vtk (legacy binary).
/// Atomic (temp + rename). Throws Error naming the file.
void write_particles(const std::string& path, const ParticleSet& particles);

/// What write_mesh adds to the geometry.
struct MeshWriteOptions {
    bool vertex_level = true;   ///< PLY: a `level` vertex property (2 or 3)
    bool color_levels = false;  ///< PLY: vertex colours, green = level 2, blue = level 3
};

/// Writes a mesh by extension: .ply (binary little-endian), .obj, .vtk (legacy binary UNSTRUCTURED_GRID of triangles, which meshio reads too),
/// .vtp (VTK XML PolyData) or .vtu (VTK XML UnstructuredGrid of triangles; the one meshio reads),
/// both with zlib-compressed base64 arrays and the levels as UInt8 point data `level`.
/// Normals: PLY nx ny nz, VTK VECTORS Normals, VTK XML point data `Normals`, OBJ vn. Attributes: PLY
/// float properties `name` or `name_x name_y name_z`, VTK SCALARS or VECTORS, VTK XML Float32
/// point data; OBJ cannot hold them and leaves them out.
/// An attribute name with white space or one that collides with another property is an Error.
/// Written to a temporary file in the target directory and renamed; never leaves a partial file.
void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options = {});

/// Throws Error unless write_mesh writes `path`'s extension (.ply, .obj, .vtk, .vtp, .vtu): for
/// checking an output name before the work that produces the mesh.
void check_mesh_extension(const std::string& path);

/// Reads a mesh written by write_mesh (.ply binary/ascii, .obj, .vtk), normals and attributes
/// included (PLY: every vertex property but x, y, z, nx, ny, nz, level, red, green, blue is an
/// attribute, `a_x a_y a_z` in a row a vector `a`); used by tests and tools.
Mesh read_mesh(const std::string& path);

/// Names accepted by generate_scene, in a fixed order.
std::vector<std::string> scene_names();

/// Generates a particle scene on a jittered lattice of spacing 2*radius (radius r in world units,
/// > 0), deterministic for a seed (same seed and frame, same positions): "block", "sphere",
/// "dam-break", "pool-and-drop" (static: `frame` is ignored) and "falling-drop", which moves
/// smoothly with `frame` (>= 0) for frame sequences; its particle count and order are the same in
/// every frame. "ball" (radius 30r), "torus" (radii 40r and 14r, axis y) and "rounded-box"
/// (half-extents 30r x 20r x 15r, edges rounded at 8r) are bodies with a known surface, centred on
/// the origin: lattice points jittered by up to a quarter spacing per axis, kept where the centre
/// lies at least r inside (a ball of radius 30r holds about 12,800 particles). Throws
/// Error for an unknown name.
ParticleSet generate_scene(const std::string& name, float radius, std::uint64_t seed = 1, int frame = 0);

}  // namespace trilevel
