// One reader per particle file format; `data` is the whole file. Each returns x, y, z per
// particle and throws Error naming `path` and, where possible, the line or byte offset.
#pragma once

#include <string>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel::io {

std::vector<float> read_vtk_points(const std::string& path, const std::string& data);
std::vector<float> read_vtu_points(const std::string& path, const std::string& data);
std::vector<float> read_bgeo_points(const std::string& path, const std::string& data);
std::vector<float> read_ply_points(const std::string& path, const std::string& data);
std::vector<float> read_xyz_points(const std::string& path, const std::string& data);

/// read_mesh on a file already in memory: `ext` (ply, obj or vtk) picks the reader, `path` names
/// the file in messages. Used by read_mesh and the fuzz target (fuzz/).
Mesh read_mesh_from_memory(const std::string& ext, const std::string& path, const std::string& data);

/// Legacy VTK POLYDATA as write_mesh writes it: POINTS, POLYGONS, optional POINT_DATA level.
Mesh read_vtk_mesh(const std::string& path, const std::string& data);

}  // namespace trilevel::io
