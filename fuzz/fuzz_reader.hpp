// The body of the fuzz targets, shared with the replay tool that runs it without libFuzzer.
#pragma once

#include <string>

/// Reads `data` with the reader of `format` (vtk, vtu, bgeo, ply, xyz, or mesh for read_mesh) and
/// aborts on anything but a good result or a clean one-line trilevel::Error.
void trilevel_fuzz_one(const std::string& format, const std::string& data);
