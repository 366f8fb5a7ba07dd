// The `trilevel` Python module: numpy arrays in and out, the GIL released while reconstructing.
//
//   import trilevel
//   vertices, triangles, stats = trilevel.reconstruct(positions, particle_radius=0.025)
//
// Positions that are already C-contiguous float32 (n, 3) arrays are read in place; anything else
// is converted once. Returned arrays own the library's vectors (no copy): their base is a capsule.
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

namespace py = pybind11;

namespace {

/// Accepted for every array argument: converted to C-contiguous T unless it already is.
template <class T>
using Array = py::array_t<T, py::array::c_style | py::array::forcecast>;

/// Moves `v` into a numpy array of `cols` columns (1-D when cols == 0) without copying it.
template <class T>
py::array_t<T> to_numpy(std::vector<T>&& v, std::size_t cols) {
    const std::size_t rows = cols ? v.size() / cols : v.size();
    std::vector<py::ssize_t> shape{py::ssize_t(rows)};
    if (cols) shape.push_back(py::ssize_t(cols));
    if (v.empty()) return py::array_t<T>(shape);  // numpy wants a real pointer; nothing to share
    auto owner = std::make_unique<std::vector<T>>(std::move(v));
    const T* data = owner->data();
    py::capsule base(owner.get(), [](void* p) { delete static_cast<std::vector<T>*>(p); });
    owner.release();  // the capsule owns it now
    return py::array_t<T>(shape, data, base);
}

/// Checks an (n, 3) array and returns n.
template <class T>
std::size_t rows_of_three(const Array<T>& a, const char* name) {
    if (a.ndim() != 2 || a.shape(1) != 3) {
        std::string shape;
        for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
        throw trilevel::Error(std::string(name) + " must be an array of shape (n, 3), got shape (" + shape + ")");
    }
    return std::size_t(a.shape(0));
}

trilevel::Params make_params(float particle_radius, const std::string& mode, float cell, float kernel_radius,
                             float curvature_threshold, std::uint64_t memory_limit) {
    trilevel::Params p;
    p.particle_radius = particle_radius;
    if (mode == "adaptive") p.mode = trilevel::Mode::Adaptive;
    else if (mode == "uniform") p.mode = trilevel::Mode::Uniform;
    else throw trilevel::Error("mode must be 'adaptive' or 'uniform', got '" + mode + "'");
    p.cell = cell;
    p.kernel_radius = kernel_radius;
    p.curvature_threshold = curvature_threshold;
    p.memory_limit_bytes = memory_limit;
    return p;
}

py::dict device_dict(const trilevel::DeviceInfo& d) {
    py::dict out;
    out["index"] = d.index;
    out["platform"] = d.platform;
    out["name"] = d.name;
    out["type"] = d.type;
    out["compute_units"] = d.compute_units;
    out["global_memory"] = d.global_memory;
    out["max_allocation"] = d.max_allocation;
    out["int64_atomics"] = d.int64_atomics;
    return out;
}

/// A Reconstructor that may be shared between Python threads: calls are serialised, because the
/// library's Reconstructor is not thread-safe and the GIL is released while it works.
struct PyReconstructor {
    explicit PyReconstructor(int device) : rec(device) {}

    py::tuple reconstruct(const Array<float>& positions, float particle_radius, const std::string& mode, float cell,
                          float kernel_radius, float curvature_threshold, std::uint64_t memory_limit,
                          bool return_levels) {
        const std::size_t n = rows_of_three(positions, "positions");
        const trilevel::Params params =
            make_params(particle_radius, mode, cell, kernel_radius, curvature_threshold, memory_limit);
        trilevel::Mesh mesh;
        trilevel::Stats stats;
        {
            py::gil_scoped_release nogil;  // `positions` stays referenced by the caller's frame
            std::lock_guard<std::mutex> lock(mutex);
            mesh = rec.reconstruct(positions.data(), n, params, &stats);
        }
        py::object stats_dict = py::module_::import("json").attr("loads")(trilevel::stats_to_json(stats, params));
        py::array_t<float> vertices = to_numpy(std::move(mesh.positions), 3);
        py::array_t<std::uint32_t> triangles = to_numpy(std::move(mesh.triangles), 3);
        if (!return_levels) return py::make_tuple(vertices, triangles, stats_dict);
        std::vector<std::uint8_t> kinds(mesh.triangle_kind.size());
        for (std::size_t i = 0; i < kinds.size(); ++i) kinds[i] = static_cast<std::uint8_t>(mesh.triangle_kind[i]);
        return py::make_tuple(vertices, triangles, stats_dict, to_numpy(std::move(mesh.vertex_level), 0),
                              to_numpy(std::move(kinds), 0));
    }

    trilevel::Reconstructor rec;
    std::mutex mutex;
};

constexpr const char* kReconstructDoc = R"(Reconstructs the closed surface mesh of a particle set.

positions: (n, 3) array of particle centres, world units (float32 C-contiguous arrays are read in
    place, anything else is converted to that first).
particle_radius: r, half the rest spacing of the particles, world units; required, > 0.
mode: "adaptive" (3-level grid: cells of 2r on flat water, r on curved and splashing water) or
    "uniform" (cells of `cell` everywhere).
cell: uniform mode: marching-cubes cell size in multiples of r; 4/cell must be an integer.
kernel_radius: SPH kernel support R in multiples of r, in [1, 16].
curvature_threshold: adaptive mode: mean cell curvature from which a coarse cell is meshed with
    cells of r; <= 0 picks the calibrated default (trilevel.default_curvature_threshold()).
memory_limit: budget in bytes for the largest allocations; 0: the device's and host's limits.
return_levels: also return vertex_level ((m,) uint8, 2 or 3) and triangle_kind ((k,) uint8:
    0 level 2, 1 level 3, 2 patch).

Returns (vertices, triangles, stats): vertices (m, 3) float32 in world units, triangles (k, 3)
uint32 vertex indices, counter-clockwise seen from outside, and stats, a dict with the keys of the
CLI's --stats JSON. Raises trilevel.Error with a one-line message on bad input or resources.)";

}  // namespace

PYBIND11_MODULE(trilevel, m) {
    m.doc() = "trilevel: adaptive surface reconstruction of SPH particle sets (3-level grids, OpenCL)";
    m.attr("__version__") = TRILEVEL_VERSION;
    py::register_exception<trilevel::Error>(m, "Error", PyExc_RuntimeError);

    py::class_<PyReconstructor>(m, "Reconstructor",
                                "Keeps an OpenCL device, its compiled kernels and buffers across frames.\n\n"
                                "device: index from trilevel.devices(); < 0: the TRILEVEL_DEVICE environment "
                                "variable, else the first GPU, else the first CPU.")
        .def(py::init<int>(), py::arg("device") = -1, py::call_guard<py::gil_scoped_release>())
        .def("reconstruct", &PyReconstructor::reconstruct, kReconstructDoc, py::arg("positions"), py::arg("particle_radius"),
             py::kw_only(), py::arg("mode") = "adaptive", py::arg("cell") = 1.0f,
             py::arg("kernel_radius") = 4.0f, py::arg("curvature_threshold") = 0.0f, py::arg("memory_limit") = 0,
             py::arg("return_levels") = false)
        .def_property_readonly("device", [](const PyReconstructor& r) { return device_dict(r.rec.device()); },
                               "The OpenCL device in use, as a dict like the entries of trilevel.devices().");

    m.def(
        "reconstruct",
        [](const Array<float>& positions, float particle_radius, const std::string& mode, float cell,
           float kernel_radius, float curvature_threshold, std::uint64_t memory_limit, int device, bool return_levels) {
            std::unique_ptr<PyReconstructor> rec;
            {
                py::gil_scoped_release nogil;
                rec = std::make_unique<PyReconstructor>(device);
            }
            return rec->reconstruct(positions, particle_radius, mode, cell, kernel_radius, curvature_threshold,
                                    memory_limit, return_levels);
        },
        (std::string(kReconstructDoc) + "\n\ndevice: as for Reconstructor. For frame sequences, reuse a "
                                        "trilevel.Reconstructor instead: it compiles the kernels once.")
            .c_str(),
        py::arg("positions"), py::arg("particle_radius"), py::kw_only(), py::arg("mode") = "adaptive",
        py::arg("cell") = 1.0f, py::arg("kernel_radius") = 4.0f, py::arg("curvature_threshold") = 0.0f,
        py::arg("memory_limit") = 0, py::arg("device") = -1, py::arg("return_levels") = false);

    m.def("devices", [] {
        py::list out;
        for (const auto& d : trilevel::list_devices()) out.append(device_dict(d));
        return out;
    }, "Every OpenCL device of every platform, as dicts (index, platform, name, type, compute_units, "
       "global_memory and max_allocation in bytes, int64_atomics).");

    m.def("default_curvature_threshold", &trilevel::default_curvature_threshold,
          "The calibrated curvature threshold used when curvature_threshold <= 0.");

    m.def("read_particles", [](const std::string& path) {
        trilevel::ParticleSet set;
        {
            py::gil_scoped_release nogil;
            set = trilevel::read_particles(path);
        }
        return to_numpy(std::move(set.positions), 3);
    }, py::arg("path"), "Reads particle positions (.vtk, .vtu, .bgeo, .ply, .xyz) as an (n, 3) float32 array.");

    m.def("write_particles", [](const std::string& path, const Array<float>& positions) {
        trilevel::ParticleSet set;
        set.positions.assign(positions.data(), positions.data() + 3 * rows_of_three(positions, "positions"));
        py::gil_scoped_release nogil;
        trilevel::write_particles(path, set);
    }, py::arg("path"), py::arg("positions"), "Writes particles by extension: .xyz, .ply, .vtk (atomically).");

    m.def("read_mesh", [](const std::string& path) {
        trilevel::Mesh mesh;
        {
            py::gil_scoped_release nogil;
            mesh = trilevel::read_mesh(path);
        }
        return py::make_tuple(to_numpy(std::move(mesh.positions), 3), to_numpy(std::move(mesh.triangles), 3));
    }, py::arg("path"), "Reads a mesh (.ply, .obj, .vtk) as (vertices (m, 3) float32, triangles (k, 3) uint32).");

    m.def("write_mesh", [](const std::string& path, const Array<float>& vertices, const Array<std::uint32_t>& triangles,
                           const std::optional<Array<std::uint8_t>>& vertex_level, bool color_levels) {
        trilevel::Mesh mesh;
        mesh.positions.assign(vertices.data(), vertices.data() + 3 * rows_of_three(vertices, "vertices"));
        mesh.triangles.assign(triangles.data(), triangles.data() + 3 * rows_of_three(triangles, "triangles"));
        if (vertex_level) mesh.vertex_level.assign(vertex_level->data(), vertex_level->data() + vertex_level->size());
        trilevel::MeshWriteOptions options;
        options.color_levels = color_levels;
        py::gil_scoped_release nogil;
        trilevel::write_mesh(path, mesh, options);
    }, py::arg("path"), py::arg("vertices"), py::arg("triangles"), py::kw_only(), py::arg("vertex_level") = py::none(),
       py::arg("color_levels") = false,
       "Writes a mesh by extension: .ply (binary; a `level` vertex property when vertex_level is given), .obj, .vtk.\n"
       "Written to a temporary file and renamed, so a failure never leaves a partial file.");

    m.def("generate_scene", [](const std::string& name, float radius, std::uint64_t seed) {
        return to_numpy(std::move(trilevel::generate_scene(name, radius, seed).positions), 3);
    }, py::arg("name"), py::arg("radius"), py::arg("seed") = 1,
       "A deterministic test scene on a jittered lattice of spacing 2*radius (world units): "
       "'block', 'sphere', 'dam-break' or 'pool-and-drop'.");
}
