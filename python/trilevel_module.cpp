// The `trilevel` Python module (compiled as trilevel._trilevel, re-exported by the package's
// __init__.py; typed in _trilevel.pyi): numpy arrays in and out, the GIL released while reconstructing.
//
//   import trilevel
//   vertices, triangles, stats = trilevel.reconstruct(positions, particle_radius=0.025)
//
// Positions that are already C-contiguous float32 (n, 3) arrays are read in place; anything else
// is converted once. Returned arrays own the library's vectors (no copy): their base is a capsule.
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>
#include <variant>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "trilevel/io.hpp"
#include "trilevel/params_table.hpp"
#include "trilevel/pipeline.hpp"
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

/// The shape of `a` as Python writes it: (4, 2), (12,).
std::string shape_of(const py::array& a) {
    std::string shape;
    for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
    return "(" + shape + (a.ndim() == 1 ? ",)" : ")");
}

/// Checks an (n, 3) array and returns n.
template <class T>
std::size_t rows_of_three(const Array<T>& a, const char* name) {
    if (a.ndim() != 2 || a.shape(1) != 3)
        throw trilevel::Error(std::string(name) + " must be an array of shape (n, 3), got shape " + shape_of(a));
    return std::size_t(a.shape(0));
}

/// An array of whole numbers (any integer dtype; an empty array of any dtype) as int64: floats
/// would be truncated and out-of-range values wrapped by a cast, silently.
Array<std::int64_t> whole_numbers(const py::object& value, const char* name) {
    const py::array a = py::array::ensure(value);  // lists and other sequences as numpy reads them
    if (!a) {
        PyErr_Clear();
        throw trilevel::Error(std::string(name) + " must be an array of integers");
    }
    const char kind = a.dtype().kind();
    if (a.size() > 0 && kind != 'i' && kind != 'u')
        throw trilevel::Error(std::string(name) + " must be an integer array, got dtype " +
                              py::cast<std::string>(py::str(a.dtype())));
    if (kind == 'u' && a.dtype().itemsize() == 8) {  // uint64 above int64's range would wrap in the cast
        const auto u = py::cast<Array<std::uint64_t>>(a);
        for (py::ssize_t i = 0; i < u.size(); ++i)
            if (u.data()[i] > std::uint64_t(INT64_MAX))
                throw trilevel::Error(std::string(name) + ": " + std::to_string(u.data()[i]) + " is out of range");
    }
    return py::cast<Array<std::int64_t>>(a);
}

/// The default of the Python keyword `python` (trilevel/params_table.hpp: Params{}'s value).
const trilevel::ParamInfo& keyword_info(const char* python) {
    for (const auto& e : trilevel::param_table())
        if (e.python == python) return e;
    throw trilevel::Error(std::string("no parameter with the Python keyword '") + python + "'");
}
template <class T>
T default_of(const char* python) {
    return std::get<T>(keyword_info(python).read(trilevel::Params{}));
}

/// A table default as the Python object the keyword takes (None where unset).
py::object default_object(const trilevel::ParamValue& v) {
    struct ToPython {
        py::object operator()(std::monostate) const { return py::none(); }
        py::object operator()(bool b) const { return py::bool_(b); }
        py::object operator()(int i) const { return py::int_(i); }
        py::object operator()(std::uint64_t u) const { return py::int_(u); }
        py::object operator()(float f) const { return py::float_(double(f)); }
        py::object operator()(const std::string& s) const { return py::str(s); }
    };
    return std::visit(ToPython{}, v);
}

/// py::arg(python) = its default from Params{}.
py::arg_v keyword(const char* python) {
    return py::arg(python) = default_object(keyword_info(python).read(trilevel::Params{}));
}

/// The keyword arguments of reconstruct() besides positions, particle_radius and device, in the
/// order of define_reconstruct's argument list (OptionTypes lists their types). Defaults: Params{}'s.
struct ReconstructOptions {
    std::string mode = default_of<std::string>("mode");
    float cell = default_of<float>("cell");
    float kernel_radius = default_of<float>("kernel_radius");
    float curvature_threshold = default_of<float>("curvature_threshold");
    float level2_tolerance = default_of<float>("level2_tolerance");
    std::uint64_t memory_limit = default_of<std::uint64_t>("memory_limit");
    float level_hysteresis = default_of<float>("level_hysteresis");
    std::string crack_closing = default_of<std::string>("crack_closing");  ///< "collapse" or "patches"
    float remove_components_below = default_of<float>("remove_components_below");  ///< particle volumes; 0 = off
    std::optional<std::vector<double>> particle_box;  ///< (x0, y0, z0, x1, y1, z1) or None (Params{}: unset)
    std::optional<std::vector<double>> clip_box;      ///< (x0, y0, z0, x1, y1, z1) or None (Params{}: unset)
    bool smooth = default_of<bool>("smooth");                   ///< Params::smooth
    int smooth_iterations = default_of<int>("smooth_iterations");  ///< Params::smooth_iterations (0: the default)
    bool sliver_cleanup = default_of<bool>("sliver_cleanup");   ///< Params::sliver_cleanup
    std::optional<std::string> normals;  ///< None (Params{}: NormalMode::None), "gradient" or "area"
    std::optional<py::dict> attributes;  ///< name -> (n,) or (n, 3) array per particle
    bool return_levels = false;
};

/// A box keyword: six numbers x0, y0, z0, x1, y1, z1 (the library checks them).
std::optional<trilevel::Box> to_box(const std::optional<std::vector<double>>& v, const char* name) {
    if (!v) return std::nullopt;
    if (v->size() != 6)
        throw trilevel::Error(std::string(name) + " must be six numbers (x0, y0, z0, x1, y1, z1), got " + std::to_string(v->size()));
    trilevel::Box b;
    for (int k = 0; k < 3; ++k) b.min[k] = float((*v)[std::size_t(k)]), b.max[k] = float((*v)[std::size_t(k) + 3]);
    return b;
}

trilevel::Params make_params(float particle_radius, const ReconstructOptions& o) {
    trilevel::Params p;
    p.particle_radius = particle_radius;
    if (o.mode == "adaptive") p.mode = trilevel::Mode::Adaptive;
    else if (o.mode == "uniform") p.mode = trilevel::Mode::Uniform;
    else throw trilevel::Error("mode must be 'adaptive' or 'uniform', got '" + o.mode + "'");
    p.cell = o.cell;
    p.kernel_radius = o.kernel_radius;
    p.curvature_threshold = o.curvature_threshold;
    p.level2_tolerance = o.level2_tolerance;
    p.memory_limit_bytes = o.memory_limit;
    p.level_hysteresis = o.level_hysteresis;
    if (o.crack_closing == "collapse") p.crack_closing = trilevel::CrackClosing::Collapse;
    else if (o.crack_closing == "patches") p.crack_closing = trilevel::CrackClosing::Patches;
    else throw trilevel::Error("crack_closing must be 'collapse' or 'patches', got '" + o.crack_closing + "'");
    p.remove_components_below = o.remove_components_below;
    p.particle_box = to_box(o.particle_box, "particle_box");
    p.clip_box = to_box(o.clip_box, "clip_box");
    p.smooth = o.smooth;
    p.smooth_iterations = o.smooth_iterations;
    p.sliver_cleanup = o.sliver_cleanup;
    if (!o.normals) p.normals = trilevel::NormalMode::None;
    else if (*o.normals == "gradient") p.normals = trilevel::NormalMode::Gradient;
    else if (*o.normals == "area") p.normals = trilevel::NormalMode::Area;
    else throw trilevel::Error("normals must be None, 'gradient' or 'area', got '" + *o.normals + "'");
    trilevel::check_params(p);  // at once: FramePipeline's frames would each fail later
    return p;
}

/// Converts {name: (n,) or (n, 3) array} to the library's attributes (copied: it takes vectors).
/// `what` names the elements in messages ("particles", "vertices").
std::vector<trilevel::Attribute> to_attributes(const py::dict& dict, std::size_t n, const char* what) {
    std::vector<trilevel::Attribute> out;
    for (const auto& [key, value] : dict) {
        trilevel::Attribute a;
        a.name = py::cast<std::string>(py::str(key));
        Array<float> values;
        try {  // numpy's own message names no attribute
            values = py::cast<Array<float>>(value);
        } catch (const py::error_already_set& e) {
            throw trilevel::Error("attribute '" + a.name + "' must be an array of numbers: " + e.what());
        } catch (const py::cast_error&) {
            throw trilevel::Error("attribute '" + a.name + "' must be an array of numbers, got " +
                                  py::cast<std::string>(py::str(py::type::of(value).attr("__name__"))));
        }
        const bool scalar = values.ndim() == 1 && std::size_t(values.shape(0)) == n;
        const bool vector = values.ndim() == 2 && std::size_t(values.shape(0)) == n && values.shape(1) == 3;
        if (!scalar && !vector)
            throw trilevel::Error("attribute '" + a.name + "' must have shape (" + std::to_string(n) + ",) or (" +
                                  std::to_string(n) + ", 3), one value per " + what + ", got shape " + shape_of(values));
        a.components = scalar ? 1 : 3;
        a.values.assign(values.data(), values.data() + values.size());
        out.push_back(std::move(a));
    }
    return out;
}

/// The library's attributes as {name: (m,) or (m, 3) float32 array}, in their order, without copies.
py::dict to_dict(std::vector<trilevel::Attribute>&& attributes) {
    py::dict out;
    for (auto& a : attributes) out[py::str(a.name)] = to_numpy(std::move(a.values), a.components == 3 ? 3 : 0);
    return out;
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

    /// (vertices, triangles, stats[, vertex_level, triangle_kind][, normals][, attributes]).
    py::tuple reconstruct(const Array<float>& positions, float particle_radius, const ReconstructOptions& o) {
        const std::size_t n = rows_of_three(positions, "positions");
        const trilevel::Params params = make_params(particle_radius, o);
        const auto attributes = o.attributes ? to_attributes(*o.attributes, n, "particle")
                                             : std::vector<trilevel::Attribute>{};
        trilevel::Mesh mesh;
        trilevel::Stats stats;
        {
            py::gil_scoped_release nogil;  // `positions` stays referenced by the caller's frame
            std::lock_guard<std::mutex> lock(mutex);
            mesh = rec.reconstruct(positions.data(), n, params, &stats, attributes);
        }
        py::list out;
        out.append(to_numpy(std::move(mesh.positions), 3));
        out.append(to_numpy(std::move(mesh.triangles), 3));
        out.append(py::module_::import("json").attr("loads")(trilevel::stats_to_json(stats, params)));
        if (o.return_levels) {
            std::vector<std::uint8_t> kinds(mesh.triangle_kind.size());
            for (std::size_t i = 0; i < kinds.size(); ++i) kinds[i] = static_cast<std::uint8_t>(mesh.triangle_kind[i]);
            out.append(to_numpy(std::move(mesh.vertex_level), 0));
            out.append(to_numpy(std::move(kinds), 0));
        }
        if (o.normals) out.append(to_numpy(std::move(mesh.normals), 3));
        if (o.attributes) out.append(to_dict(std::move(mesh.attributes)));
        return py::tuple(out);
    }

    void reset_history() {
        py::gil_scoped_release nogil;
        std::lock_guard<std::mutex> lock(mutex);
        rec.reset_history();
    }

    trilevel::Reconstructor rec;
    std::mutex mutex;
};

/// trilevel.FramePipeline: a simulator's frames meshed on a worker thread (trilevel/pipeline.hpp)
/// while Python steps the next one; finished frames are collected here and handed back by push()
/// and finish() on the caller's thread, so no Python code runs on the pipeline's threads.
struct PyFramePipeline {
    PyFramePipeline(PyReconstructor& rec, float particle_radius, const ReconstructOptions& o)
        : params(make_params(particle_radius, o)) {
        pipe.emplace(rec.rec, params, [this](trilevel::PipelineFrame& f) {
            std::lock_guard<std::mutex> lock(mutex);
            done.push_back(std::move(f));
        });
    }
    ~PyFramePipeline() {
        py::gil_scoped_release nogil;  // the worker may still be meshing
        pipe.reset();
    }

    py::list push(const Array<float>& positions) {
        const std::size_t n = rows_of_three(positions, "positions");
        std::vector<float> xyz(positions.data(), positions.data() + 3 * n);
        {
            py::gil_scoped_release nogil;
            pipe->push(std::move(xyz));
        }
        return take();
    }

    py::list finish() {
        {
            py::gil_scoped_release nogil;
            pipe->finish();
        }
        return take();
    }

    /// The frames finished so far: (index, vertices, triangles, stats[, normals]), or
    /// (index, None, None, message) for a frame that failed.
    py::list take() {
        std::vector<trilevel::PipelineFrame> frames;
        {
            std::lock_guard<std::mutex> lock(mutex);
            frames.swap(done);
        }
        py::list out;
        for (auto& f : frames) {
            if (f.error) {
                std::string message;
                try {
                    std::rethrow_exception(f.error);
                } catch (const std::exception& e) {
                    message = e.what();
                }
                out.append(py::make_tuple(f.index, py::none(), py::none(), message));
                continue;
            }
            py::list t;
            t.append(f.index);
            t.append(to_numpy(std::move(f.mesh.positions), 3));
            t.append(to_numpy(std::move(f.mesh.triangles), 3));
            t.append(py::module_::import("json").attr("loads")(trilevel::stats_to_json(f.stats, params)));
            if (params.normals != trilevel::NormalMode::None) t.append(to_numpy(std::move(f.mesh.normals), 3));
            out.append(py::tuple(t));
        }
        return out;
    }

    trilevel::Params params;
    std::mutex mutex;
    std::vector<trilevel::PipelineFrame> done;
    std::optional<trilevel::FramePipeline> pipe;
};

/// The types of ReconstructOptions' fields up to normals, in order: the bound functions take
/// these after positions and particle_radius and build the struct from them (aggregate
/// initialisation); reconstruct also takes attributes and return_levels.
using MeshOptionTypes = std::tuple<std::string, float, float, float, float, std::uint64_t, float, std::string, float,
                                   std::optional<std::vector<double>>, std::optional<std::vector<double>>, bool, int, bool,
                                   std::optional<std::string>>;
using OptionTypes = decltype(std::tuple_cat(std::declval<MeshOptionTypes>(), std::tuple<std::optional<py::dict>, bool>()));

/// The keywords of MeshOptionTypes' fields, with their defaults.
auto mesh_option_keywords() {
    return std::make_tuple(keyword("mode"), keyword("cell"), keyword("kernel_radius"), keyword("curvature_threshold"),
                           keyword("level2_tolerance"), keyword("memory_limit"), keyword("level_hysteresis"),
                           keyword("crack_closing"), keyword("remove_components_below"), keyword("particle_box"),
                           keyword("clip_box"), keyword("smooth"), keyword("smooth_iterations"), keyword("sliver_cleanup"),
                           keyword("normals"));
}

/// Defines Reconstructor.reconstruct (on `cls`) and reconstruct() (on `m`, with a device) with the
/// keyword arguments below, which name ReconstructOptions' fields in order with their defaults.
template <class... Option>
void define_reconstruct(py::class_<PyReconstructor>& cls, py::module_& m, const char* method_doc, const char* function_doc,
                        std::tuple<Option...>*) {
    const auto args = std::tuple_cat(std::make_tuple(py::arg("positions"), py::arg("particle_radius"), py::kw_only()),
                                     mesh_option_keywords(),
                                     std::make_tuple(py::arg("attributes") = py::none(), py::arg("return_levels") = false));
    std::apply([&](auto... a) {
        cls.def("reconstruct",
                [](PyReconstructor& rec, const Array<float>& positions, float particle_radius, Option... option) {
                    return rec.reconstruct(positions, particle_radius, ReconstructOptions{std::move(option)...});
                },
                method_doc, a...);
        m.def("reconstruct",
              [](const Array<float>& positions, float particle_radius, Option... option, int device) {
                  std::unique_ptr<PyReconstructor> rec;
                  {
                      py::gil_scoped_release nogil;
                      rec = std::make_unique<PyReconstructor>(device);
                  }
                  return rec->reconstruct(positions, particle_radius, ReconstructOptions{std::move(option)...});
              },
              function_doc, a..., py::arg("device") = -1);
    }, args);
}

/// Defines FramePipeline(reconstructor, particle_radius, *, <MeshOptionTypes' keywords>) on `cls`.
template <class... Option>
void define_pipeline_init(py::class_<PyFramePipeline>& cls, std::tuple<Option...>*) {
    const auto args = std::tuple_cat(std::make_tuple(py::arg("reconstructor"), py::arg("particle_radius"), py::kw_only()),
                                     mesh_option_keywords(), std::make_tuple(py::keep_alive<1, 2>()));
    std::apply([&](auto... a) {
        cls.def(py::init([](PyReconstructor& rec, float particle_radius, Option... option) {
                    return std::make_unique<PyFramePipeline>(
                        rec, particle_radius, ReconstructOptions{std::move(option)..., std::nullopt, false});
                }),
                a...);
    }, args);
}

/// Defines _check_params(particle_radius, *, <MeshOptionTypes' keywords>): raises trilevel.Error as
/// reconstruct would for the options alone, with no device (trilevel.dask checks a run's options
/// on the client, which may have no OpenCL, before any frame is sent out).
template <class... Option>
void define_check_params(py::module_& m, std::tuple<Option...>*) {
    const auto args = std::tuple_cat(std::make_tuple(py::arg("particle_radius"), py::kw_only()), mesh_option_keywords());
    std::apply([&](auto... a) {
        m.def("_check_params", [](float particle_radius, Option... option) {
            make_params(particle_radius, ReconstructOptions{std::move(option)..., std::nullopt, false});
        }, a...);
    }, args);
}

/// A table default as Python writes it: 'adaptive', 4.0, None, False.
std::string python_text(const trilevel::ParamValue& v) {
    if (std::holds_alternative<std::monostate>(v)) return "None";
    if (const bool* b = std::get_if<bool>(&v)) return *b ? "True" : "False";
    if (const std::string* s = std::get_if<std::string>(&v)) return "'" + *s + "'";
    std::string text = trilevel::param_value_text(v);
    if (std::holds_alternative<float>(v) && text.find_first_of(".en") == std::string::npos) text += ".0";
    return text;
}

/// `text` wrapped at 100 columns, the lines after the first indented by 4 (docstring paragraphs).
std::string wrapped(const std::string& text) {
    std::string out, line;
    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find(' ', start);
        if (end == std::string::npos) end = text.size();
        const std::string word = text.substr(start, end - start);
        if (!line.empty() && line.size() + 1 + word.size() > 100) {
            out += line + "\n";
            line = "    ";
        } else if (!line.empty() && line != "    ") line += ' ';
        line += word;
        start = end + 1;
    }
    return out + line + "\n";
}

/// One paragraph per keyword, from the parameter table: "keyword: help. Default: value (meaning);
/// the CLI's: value" (the CLI's --help shows the same line).
std::string keyword_docs(std::initializer_list<const char*> keywords) {
    std::string out;
    for (const char* k : keywords) {
        const trilevel::ParamInfo& e = keyword_info(k);
        std::string text = e.python + ": " + e.help + ".";
        if (e.required) text += " Required.";
        else {
            text += " Default: " + python_text(e.read(trilevel::Params{}));
            if (!e.default_means.empty()) text += " (" + e.default_means + ")";
            if (!e.cli_default.empty()) text += "; the CLI's: " + e.cli_default;
            text += ".";
        }
        out += wrapped(text);
    }
    return out;
}

/// The docstring of Reconstructor.reconstruct; its keywords' lines come from the parameter table.
std::string reconstruct_doc() {
    return "Reconstructs the closed surface mesh of a particle set.\n\n"
           "positions: (n, 3) array of particle centres, world units (float32 C-contiguous arrays are read in\n"
           "    place, anything else is converted to that first).\n" +
           keyword_docs({"particle_radius", "mode", "cell", "kernel_radius", "curvature_threshold", "level2_tolerance",
                         "memory_limit", "level_hysteresis", "crack_closing", "remove_components_below", "particle_box",
                         "clip_box", "smooth", "smooth_iterations", "sliver_cleanup", "normals"}) +
           R"(attributes: {name: array} of per-particle values, (n,) for scalars or (n, 3) for vectors (copied,
    converted to float32, finite): adds them interpolated at the vertices (Shepard-normalised SPH
    weights; a constant attribute stays exactly constant).
return_levels: also return vertex_level ((m,) uint8, 2 or 3) and triangle_kind ((k,) uint8:
    0 level 2, 1 level 3, 2 patch).

Boxes are sequences of six numbers or None. curvature_threshold 0 picks
trilevel.default_curvature_threshold(). Successive calls on one Reconstructor are frames of one
sequence for level_hysteresis; stats["level_flips"] reports the level changes, and
stats["components_removed"], stats["particles_outside_box"] and stats["clip_cap_triangles"] what
the other options did.

Returns (vertices, triangles, stats): vertices (m, 3) float32 in world units, triangles (k, 3)
uint32 vertex indices, counter-clockwise seen from outside, and stats, a dict with the keys of the
CLI's --stats JSON. The options add outputs after these, in this order (like numpy.unique's
return_* flags): vertex_level and triangle_kind (return_levels), normals ((m, 3) float32, unit,
outward; when normals is given), attributes ({name: (m,) or (m, 3) float32}, in the input's order;
when attributes is given). Raises trilevel.Error with a one-line message on bad input or resources.)";
}

}  // namespace

// Imported as `trilevel` (python/trilevel/__init__.py re-exports it).
PYBIND11_MODULE(_trilevel, m) {
    m.doc() = "trilevel: adaptive surface reconstruction of SPH particle sets (3-level grids, OpenCL)";
    m.attr("__version__") = TRILEVEL_VERSION;
    py::register_exception<trilevel::Error>(m, "Error", PyExc_RuntimeError);

    py::class_<PyReconstructor> cls(m, "Reconstructor",
                                    "Keeps an OpenCL device, its compiled kernels and buffers across frames.\n\n"
                                    "device: index from trilevel.devices(); < 0: the TRILEVEL_DEVICE environment "
                                    "variable, else the first GPU, else the first CPU.\n"
                                    "Successive reconstruct() calls are taken as successive frames of one "
                                    "sequence (see level_hysteresis); reset_history() starts a new one.");
    cls.def(py::init<int>(), py::arg("device") = -1, py::call_guard<py::gil_scoped_release>())
        .def("reset_history", &PyReconstructor::reset_history,
             "Forgets the previous frame's levels: call before the first frame of a new sequence (or between "
             "unrelated inputs) so that it is reconstructed as if alone. A change of particle_radius, "
             "kernel_radius, mode or cell resets the history too.")
        .def_property_readonly("device", [](const PyReconstructor& r) { return device_dict(r.rec.device()); },
                               "The OpenCL device in use, as a dict like the entries of trilevel.devices().");
    static const std::string method_doc = reconstruct_doc();
    static const std::string one_shot_doc =
        method_doc +
        "\n\ndevice: as for Reconstructor. For frame sequences, reuse a trilevel.Reconstructor instead: it "
        "compiles the kernels once (and remembers the levels for level_hysteresis).";
    define_reconstruct(cls, m, method_doc.c_str(), one_shot_doc.c_str(), static_cast<OptionTypes*>(nullptr));

    static const std::string pipeline_doc = R"(Meshes a sequence's frames on a worker thread while the caller
produces the next (a simulator steps it): push(positions) hands frame k over and returns once frame
k - 1 is meshed, with the frames finished so far. The meshes, stats and level history are those of
calling reconstructor.reconstruct frame by frame with the same options (bit for bit). One input and
one mesh more than one frame at a time are alive; memory_limit counts them.

reconstructor: a trilevel.Reconstructor, not to be used otherwise until finish().
)" + keyword_docs({"particle_radius", "mode", "cell", "kernel_radius", "curvature_threshold", "level2_tolerance",
                   "memory_limit", "level_hysteresis", "crack_closing", "remove_components_below", "particle_box",
                   "clip_box", "smooth", "smooth_iterations", "sliver_cleanup", "normals"}) +
                                             R"(
push(positions) and finish() return lists of (index, vertices, triangles, stats[, normals]) in frame
order (index: 0 for the first push), or (index, None, None, message) for a frame that failed (the
next frames go on). finish() waits for every frame; no push after it.)";
    py::class_<PyFramePipeline> pipeline(m, "FramePipeline", pipeline_doc.c_str());
    define_pipeline_init(pipeline, static_cast<MeshOptionTypes*>(nullptr));
    define_check_params(m, static_cast<MeshOptionTypes*>(nullptr));
    pipeline.def("push", &PyFramePipeline::push, py::arg("positions"),
             "Hands the next frame's (n, 3) positions over (copied); returns the frames finished so far.")
        .def("finish", &PyFramePipeline::finish, "Waits for every frame; returns the frames not yet returned.");

    m.def("_parameter_table", [] {
        py::list out;
        for (const auto& e : trilevel::param_table()) {
            py::dict d;
            d["field"] = e.field;
            d["cli"] = e.cli;
            d["python"] = e.python;
            d["help"] = e.help;
            d["required"] = e.required;
            d["default"] = e.required ? py::object(py::none()) : default_object(e.read(trilevel::Params{}));
            d["default_means"] = e.default_means;
            d["cli_default"] = e.cli_default;
            out.append(d);
        }
        return out;
    }, "The parameter table (trilevel/params_table.hpp) that the keywords' defaults and docs come from, for tests.");

    m.def("devices", [] {
        py::list out;
        for (const auto& d : trilevel::list_devices()) out.append(device_dict(d));
        return out;
    }, "Every OpenCL device of every platform, as dicts (index, platform, name, type, compute_units, "
       "global_memory and max_allocation in bytes, int64_atomics).");

    m.def("default_curvature_threshold", &trilevel::default_curvature_threshold,
          "The calibrated curvature threshold used when curvature_threshold is 0.");

    m.def("read_particles", [](const std::filesystem::path& file, std::optional<std::vector<std::string>> attributes,
                               bool drop_invalid) -> py::object {
        const std::string path = file.string();
        trilevel::ReadOptions options;
        if (attributes) options.attributes = *attributes;
        options.drop_invalid = drop_invalid;
        trilevel::ParticleSet set;
        {
            py::gil_scoped_release nogil;
            set = trilevel::read_particles(path, options);
        }
        if (set.dropped_invalid > 0) {
            const std::string warning = path + ": dropped " + std::to_string(set.dropped_invalid) +
                                        " particles with NaN/Inf coordinates";
            if (PyErr_WarnEx(PyExc_RuntimeWarning, warning.c_str(), 1) != 0) throw py::error_already_set();
        }
        py::array_t<float> positions = to_numpy(std::move(set.positions), 3);
        if (!attributes) return positions;
        return py::make_tuple(positions, to_dict(std::move(set.attributes)));
    }, py::arg("path"), py::arg("attributes") = py::none(), py::kw_only(), py::arg("drop_invalid") = false,
       R"(Reads particles (.vtk, .vtu, .bgeo, .ply, .xyz); returns their positions as an (n, 3) float32 array.

attributes: names of per-particle attributes to read as well (VTK point data, VTU PointData, BGEO
    point attributes, PLY vertex properties); then returns (positions, {name: (n,) or (n, 3)
    float32}), in the order asked, ready for reconstruct(..., attributes=...). A name the file
    lacks raises trilevel.Error listing the names it has.
drop_invalid: drop particles with a NaN/Inf coordinate (and their attributes) with a
    RuntimeWarning giving their number, instead of raising trilevel.Error.)");

    m.def("write_particles", [](const std::filesystem::path& file, const Array<float>& positions) {
        const std::string path = file.string();
        trilevel::ParticleSet set;
        set.positions.assign(positions.data(), positions.data() + 3 * rows_of_three(positions, "positions"));
        py::gil_scoped_release nogil;
        trilevel::write_particles(path, set);
    }, py::arg("path"), py::arg("positions"), "Writes particles by extension: .xyz, .ply, .vtk (atomically).");

    m.def("read_mesh", [](const std::filesystem::path& file, bool return_normals, bool return_attributes) {
        const std::string path = file.string();
        trilevel::Mesh mesh;
        {
            py::gil_scoped_release nogil;
            mesh = trilevel::read_mesh(path);
        }
        py::list out;
        out.append(to_numpy(std::move(mesh.positions), 3));
        out.append(to_numpy(std::move(mesh.triangles), 3));
        if (return_normals) out.append(mesh.normals.empty() ? py::object(py::none()) : to_numpy(std::move(mesh.normals), 3));
        if (return_attributes) out.append(to_dict(std::move(mesh.attributes)));
        return py::tuple(out);
    }, py::arg("path"), py::kw_only(), py::arg("return_normals") = false, py::arg("return_attributes") = false,
       R"(Reads a mesh (.ply, .obj, .vtk) as (vertices (m, 3) float32, triangles (k, 3) uint32).

return_normals: also return the per-vertex normals ((m, 3) float32; None when the file has none).
return_attributes: also return the vertex attributes ({name: (m,) or (m, 3) float32}; PLY: every
    vertex property but x y z, nx ny nz, level and colours, `a_x a_y a_z` as one vector `a`).)");

    m.def("_check_mesh_extension", [](const std::filesystem::path& file) { trilevel::check_mesh_extension(file.string()); },
          py::arg("path"), "Raises trilevel.Error unless write_mesh writes the path's extension.");
    m.def("write_mesh", [](const std::filesystem::path& file, const Array<float>& vertices, const py::object& triangles,
                           const std::optional<py::object>& vertex_level, bool color_levels,
                           const std::optional<Array<float>>& normals, const std::optional<py::dict>& attributes) {
        const std::string path = file.string();
        trilevel::Mesh mesh;
        mesh.positions.assign(vertices.data(), vertices.data() + 3 * rows_of_three(vertices, "vertices"));
        const Array<std::int64_t> tri = whole_numbers(triangles, "triangles");
        const std::size_t k = rows_of_three(tri, "triangles");
        mesh.triangles.resize(3 * k);
        for (std::size_t i = 0; i < 3 * k; ++i) {
            if (tri.data()[i] < 0 || tri.data()[i] > std::int64_t(UINT32_MAX))
                throw trilevel::Error("triangles must hold vertex indices from 0, got " + std::to_string(tri.data()[i]) +
                                      " in triangle " + std::to_string(i / 3));
            mesh.triangles[i] = std::uint32_t(tri.data()[i]);
        }
        if (vertex_level) {
            const Array<std::int64_t> level = whole_numbers(*vertex_level, "vertex_level");
            for (py::ssize_t i = 0; i < level.size(); ++i) {
                if (level.data()[i] != 2 && level.data()[i] != 3)
                    throw trilevel::Error("vertex_level must be 2 or 3 per vertex, got " + std::to_string(level.data()[i]) +
                                          " at vertex " + std::to_string(i));
                mesh.vertex_level.push_back(std::uint8_t(level.data()[i]));
            }
        }
        if (normals) mesh.normals.assign(normals->data(), normals->data() + 3 * rows_of_three(*normals, "normals"));
        if (attributes) mesh.attributes = to_attributes(*attributes, mesh.vertex_count(), "vertex");
        trilevel::MeshWriteOptions options;
        options.color_levels = color_levels;
        py::gil_scoped_release nogil;
        trilevel::write_mesh(path, mesh, options);
    }, py::arg("path"), py::arg("vertices"), py::arg("triangles"), py::kw_only(), py::arg("vertex_level") = py::none(),
       py::arg("color_levels") = false, py::arg("normals") = py::none(), py::arg("attributes") = py::none(),
       R"(Writes a mesh by extension: .ply (binary), .obj, .vtk, .vtp, .vtu (.vtp and .vtu: VTK XML; meshio reads all but .vtp).

vertex_level: (m,) 2 or 3 per vertex: a PLY `level` vertex property (color_levels: and colours).
normals: (m, 3) per-vertex normals: PLY nx ny nz, VTK NORMALS, VTK XML `Normals`, OBJ vn.
attributes: {name: (m,) or (m, 3) array} per vertex: PLY properties `name` or `name_x name_y
    name_z`, VTK SCALARS or VECTORS; OBJ leaves them out.
Written to a temporary file and renamed, so a failure never leaves a partial file.)");

    m.def("scene_names", &trilevel::scene_names, "The names generate_scene accepts.");

    m.def("generate_scene", [](const std::string& name, float radius, std::uint64_t seed, int frame) {
        return to_numpy(std::move(trilevel::generate_scene(name, radius, seed, frame).positions), 3);
    }, py::arg("name"), py::arg("radius"), py::arg("seed") = 1, py::arg("frame") = 0,
       "A deterministic test scene on a jittered lattice of spacing 2*radius (world units): "
       "'block', 'sphere', 'dam-break', 'pool-and-drop' or 'falling-drop', which moves with `frame` "
       "(>= 0; same particle count and order in every frame) for frame sequences.");
}
