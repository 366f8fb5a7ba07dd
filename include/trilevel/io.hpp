// Particle readers, mesh writers and the scene generator of trilevel.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// A per-particle quantity read alongside the positions (velocity, density, ...).
struct ParticleAttribute {
    std::string name;           ///< as named in the file
    int components = 1;         ///< 1 (scalar) or 3 (vector)
    std::vector<float> values;  ///< `components` floats per particle, in particle order
};

/// Particle positions read from a file, x, y, z per particle, in file order.
struct ParticleSet {
    std::vector<float> positions;
    std::vector<ParticleAttribute> attributes;  ///< only those asked for in ReadOptions::attributes
    std::size_t dropped_invalid = 0;            ///< particles dropped by ReadOptions::drop_invalid
    std::size_t size() const { return positions.size() / 3; }
};

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
/// (little-endian float32 triplets). Throws Error naming the file and what is wrong.
ParticleSet read_particles(const std::string& path, const ReadOptions& options = {});

/// Writes particles by extension: .xyz, .ply (binary), .vtk (legacy binary). Atomic (temp + rename).
void write_particles(const std::string& path, const ParticleSet& particles);

struct MeshWriteOptions {
    bool vertex_level = true;   ///< PLY: a `level` vertex property (2 or 3)
    bool color_levels = false;  ///< PLY: vertex colours, green = level 2, blue = level 3
};

/// Writes a mesh by extension: .ply (binary little-endian), .obj, .vtk (legacy binary POLYDATA).
/// Written to a temporary file in the target directory and renamed; never leaves a partial file.
void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options = {});

/// Reads a mesh written by write_mesh (.ply binary/ascii, .obj, .vtk); used by tests and tools.
Mesh read_mesh(const std::string& path);

/// Names accepted by generate_scene.
std::vector<std::string> scene_names();

/// Generates a particle scene on a jittered lattice of spacing 2*radius, deterministic for a seed:
/// "block", "sphere", "dam-break", "pool-and-drop". Throws Error for an unknown name.
ParticleSet generate_scene(const std::string& name, float radius, std::uint64_t seed = 1);

}  // namespace trilevel
