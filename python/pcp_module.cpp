// The Python module `pcp` (pybind11): the library's reconstruction, I/O, evaluation and prior
// training on numpy arrays. Errors arrive as pcp.Error (a RuntimeError) with the library's message;
// the GIL is released while the library works; Ctrl-C (and an exception or False from a progress
// callable) cancels a running call at its next progress report.
#include "pcp/cloud/normalize.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/io/io.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/settings.hpp"
#include "pcp/train/prior.hpp"

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <omp.h>

#include <optional>
#include <string>
#include <vector>

namespace py = pybind11;

namespace {

/// Raised when a progress callable returned False.
struct Cancelled {};

/// An (N, 3) float32/float64 C-contiguous array of finite values -> pcp::Points; a clear
/// ValueError otherwise.
pcp::Points to_points(const py::handle& object, const char* what) {
    if (!py::isinstance<py::array>(object))
        throw py::value_error(std::string(what) + ": expected a numpy array of shape (N, 3), got " +
                              std::string(py::str(py::type::of(object).attr("__name__"))));
    const auto array = py::reinterpret_borrow<py::array>(object);
    const bool f32 = array.dtype().is(py::dtype::of<float>()), f64 = array.dtype().is(py::dtype::of<double>());
    if (!f32 && !f64)
        throw py::value_error(std::string(what) + ": expected float32 or float64 values, got dtype " +
                              std::string(py::str(array.dtype())));
    if (array.ndim() != 2 || array.shape(1) != 3) {
        std::string shape = "(";
        for (py::ssize_t i = 0; i < array.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(array.shape(i));
        throw py::value_error(std::string(what) + ": expected shape (N, 3), got " + shape + (array.ndim() == 1 ? ",)" : ")"));
    }
    if (!(array.flags() & py::array::c_style))
        throw py::value_error(std::string(what) + ": the array is not C-contiguous (a slice or a transpose); "
                                                  "pass numpy.ascontiguousarray(points)");
    const auto n = static_cast<Eigen::Index>(array.shape(0));
    pcp::Points points(n, 3);
    if (f64) points = Eigen::Map<const pcp::Points>(static_cast<const double*>(array.data()), n, 3);
    else points = Eigen::Map<const pcp::PointsF>(static_cast<const float*>(array.data()), n, 3).cast<double>();
    for (Eigen::Index i = 0; i < n; ++i)
        if (!points.row(i).allFinite())
            throw py::value_error(std::string(what) + ": row " + std::to_string(i) + " is not finite (NaN or infinity)");
    return points;
}

pcp::Mesh to_mesh(const py::handle& vertices, const py::handle& faces, const char* what) {
    pcp::Mesh mesh;
    mesh.vertices = to_points(vertices, what);
    const auto f = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(faces);
    if (!f || f.ndim() != 2 || f.shape(1) != 3)
        throw py::value_error(std::string(what) + ": faces must be an integer array of shape (F, 3)");
    mesh.faces.resize(static_cast<Eigen::Index>(f.shape(0)), 3);
    const auto view = f.unchecked<2>();
    for (py::ssize_t i = 0; i < f.shape(0); ++i)
        for (int c = 0; c < 3; ++c) {
            const std::int64_t v = view(i, c);
            if (v < 0 || v >= mesh.vertices.rows())
                throw py::value_error(std::string(what) + ": face " + std::to_string(i) + " names vertex " + std::to_string(v) +
                                      " of " + std::to_string(mesh.vertices.rows()));
            mesh.faces(static_cast<Eigen::Index>(i), c) = static_cast<std::int32_t>(v);
        }
    return mesh;
}

py::array_t<double> points_array(const pcp::Points& p) {
    py::array_t<double> out({static_cast<py::ssize_t>(p.rows()), static_cast<py::ssize_t>(3)});
    Eigen::Map<pcp::Points>(out.mutable_data(), p.rows(), 3) = p;
    return out;
}

py::array_t<std::int32_t> faces_array(const pcp::Mesh& m) {
    py::array_t<std::int32_t> out({static_cast<py::ssize_t>(m.faces.rows()), static_cast<py::ssize_t>(3)});
    Eigen::Map<Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>>(out.mutable_data(), m.faces.rows(), 3) = m.faces;
    return out;
}

/// Thread count and GEMM precision for one call, restored afterwards.
class CallSettings {
public:
    CallSettings(int threads, const std::string& precision) : threads_(omp_get_max_threads()), precision_(pcp::nn::gemm_precision()) {
        if (threads < 0) throw py::value_error("threads must be >= 0 (0: all cores)");
        pcp::nn::set_gemm_precision(pcp::nn::parse_precision(precision));
        if (threads > 0) omp_set_num_threads(threads);
    }
    ~CallSettings() {
        omp_set_num_threads(threads_);
        pcp::nn::set_gemm_precision(precision_);
    }
    CallSettings(const CallSettings&) = delete;
    CallSettings& operator=(const CallSettings&) = delete;

private:
    int threads_;
    pcp::nn::Precision precision_;
};

/// The library's progress callback for one call: checks for Ctrl-C and calls the user's callable
/// (stage, step, total) with the GIL held; either one can cancel. The first Python exception is
/// kept and raised when the call returns.
class ProgressBridge {
public:
    explicit ProgressBridge(py::object callable) : callable_(std::move(callable)) {}
    pcp::ProgressCallback callback() {
        return [this](const pcp::Progress& p) {
            py::gil_scoped_acquire gil;
            if (error_ || cancelled_) return false;
            if (PyErr_CheckSignals() != 0) {
                error_ = py::error_already_set();
                return false;
            }
            if (callable_.is_none()) return true;
            try {
                const py::object keep = callable_(p.stage, p.step, p.total);
                if (!keep.is_none() && !keep.cast<bool>()) cancelled_ = true;
            } catch (py::error_already_set& e) {
                error_ = std::move(e);
            }
            return !(error_ || cancelled_);
        };
    }
    /// Raises what stopped the call, if anything did (with the GIL held).
    void raise_if_stopped() {
        if (error_) {
            py::error_already_set e = std::move(*error_);
            error_.reset();
            throw e;
        }
        if (cancelled_) throw Cancelled{};
    }

private:
    py::object callable_;
    std::optional<py::error_already_set> error_;
    bool cancelled_ = false;
};

py::object reconstruct(const py::handle& points_obj, const std::string& preset, const std::optional<std::string>& prior_path,
                       int threads, const py::object& progress, bool normals, std::uint64_t seed, const std::string& precision,
                       std::optional<std::int64_t> steps, std::optional<std::int64_t> prior_steps, std::optional<int> resolution,
                       const py::dict& settings) {
    pcp::ReconstructOptions o = pcp::ReconstructOptions::preset(preset);
    o.fit.schedule.seed = o.self_prior.schedule.seed = seed;
    // The library's settings table checks every value (pcp/settings.hpp): a bad one is a ValueError
    // naming it, as on the command line.
    const auto set = [&o](const std::string& name, const std::string& value) {
        try {
            pcp::set_option(o, name, value);
        } catch (const pcp::Error& e) {
            throw py::value_error(e.what());
        }
    };
    if (prior_steps && *prior_steps < 1) throw py::value_error("prior_steps must be >= 1");
    if (steps) set("steps", std::to_string(*steps));
    if (prior_steps) set("prior-steps", std::to_string(*prior_steps));
    if (resolution) set("resolution", std::to_string(*resolution));
    for (const auto& item : settings) {
        const std::string name = py::str(item.first);
        const py::handle v = item.second;
        set(name, py::isinstance<py::bool_>(v) ? (v.cast<bool>() ? "on" : "off") : std::string(py::str(v)));
    }
    const pcp::Points points = to_points(points_obj, "points");
    pcp::check_point_cloud(points, "points", pcp::min_points_for(o.fit.sampling));
    pcp::LocalPrior prior;
    if (prior_path) prior = pcp::load_prior(*prior_path);
    ProgressBridge bridge(progress);
    o.progress = bridge.callback();
    pcp::Mesh mesh;
    pcp::Points point_normals;
    pcp::ReconstructReport report;
    {
        CallSettings settings(threads, precision);
        py::gil_scoped_release release;
        try {
            mesh = pcp::reconstruct(points, prior_path ? &prior : nullptr, o, &report, normals ? &point_normals : nullptr);
        } catch (const pcp::Error&) {
            py::gil_scoped_acquire gil;
            bridge.raise_if_stopped();  // a cancelled grid stage throws: report why it stopped
            throw;
        }
    }
    bridge.raise_if_stopped();
    if (report.cancelled) throw Cancelled{};
    if (normals) return py::make_tuple(points_array(mesh.vertices), faces_array(mesh), points_array(point_normals));
    return py::make_tuple(points_array(mesh.vertices), faces_array(mesh));
}

py::dict metrics_dict(const pcp::Metrics& m) {
    py::dict d;
    d["chamfer_l1"] = m.chamfer_l1;
    d["chamfer_l2"] = m.chamfer_l2;
    d["chamfer_l2_x100"] = 100 * m.chamfer_l2;
    d["normal_consistency"] = m.normal_consistency;
    d["hausdorff"] = m.hausdorff;
    py::dict f;
    for (const pcp::FScore& s : m.fscores) f[py::float_(s.threshold)] = s.fscore;
    d["fscore"] = f;
    return d;
}

py::dict evaluate(const py::tuple& pred, const py::tuple& gt, const std::string& protocol, std::int64_t samples, std::uint64_t seed,
                  bool floor) {
    if (pred.size() != 2 || gt.size() != 2) throw py::value_error("pred and gt must be (vertices, faces) pairs");
    const pcp::Mesh p = to_mesh(pred[0], pred[1], "pred"), g = to_mesh(gt[0], gt[1], "gt");
    pcp::EvalOptions o;
    o.protocol = pcp::parse_eval_protocol(protocol);
    if (samples < 0) throw py::value_error("samples must be >= 0");
    o.samples = samples;
    o.seed = seed;
    o.with_floor = floor;
    pcp::EvalResult r;
    {
        py::gil_scoped_release release;
        r = pcp::evaluate(p, g, o);
    }
    py::dict d = metrics_dict(r.metrics);
    d["samples"] = r.samples;
    d["protocol"] = pcp::to_string(o.protocol);
    if (floor) d["floor"] = metrics_dict(r.floor);
    return d;
}

py::dict train_prior(const py::list& clouds, const std::string& output, const std::string& preset, std::optional<int> epochs,
                     std::optional<std::int64_t> steps, int threads, std::uint64_t seed, const std::string& precision,
                     const py::object& progress) {
    if (clouds.empty()) throw py::value_error("clouds: give at least one (N, 3) array");
    pcp::PriorTrainOptions o = pcp::PriorTrainOptions::preset(preset);
    o.schedule.seed = seed;
    if (epochs) {
        if (*epochs < 1) throw py::value_error("epochs must be >= 1");
        o.epochs = *epochs;
    }
    if (steps) {
        if (*steps < 1) throw py::value_error("steps must be >= 1");
        o.max_steps = *steps;
    }
    std::vector<pcp::TrainingCloud> list;
    for (std::size_t i = 0; i < clouds.size(); ++i) {
        const std::string name = "clouds[" + std::to_string(i) + "]";
        list.push_back({name, to_points(clouds[i], name.c_str())});
        pcp::check_point_cloud(list.back().points, name, pcp::min_points_for(o.sampling));
    }
    pcp::check_output_path(output, {});
    ProgressBridge bridge(progress);
    o.schedule.progress = bridge.callback();
    pcp::LocalPrior prior;
    {
        CallSettings settings(threads, precision);
        py::gil_scoped_release release;
        pcp::PriorTrainer trainer(list, o);
        const bool done = trainer.run();
        if (done) prior = trainer.prior();
    }
    bridge.raise_if_stopped();
    pcp::save_prior(output, prior);
    py::dict d;
    d["path"] = output;
    d["steps"] = prior.provenance.steps;
    d["final_loss"] = prior.provenance.final_loss;
    return d;
}

}  // namespace

PYBIND11_MODULE(pcp, m) {
    m.doc() = "libpcp: surface reconstruction from unoriented point clouds by Predictive Context Priors (CVPR 2022)";
    static py::exception<pcp::Error> error(m, "Error", PyExc_RuntimeError);
    static py::exception<Cancelled> cancelled(m, "Cancelled", PyExc_RuntimeError);
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const pcp::Error& e) {
            PyErr_SetString(error.ptr(), e.what());
        } catch (const Cancelled&) {
            PyErr_SetString(cancelled.ptr(), "cancelled by the progress callable");
        }
    });

    m.def("reconstruct", &reconstruct, py::arg("points"), py::kw_only(), py::arg("preset") = "default",
          py::arg("prior") = py::none(), py::arg("threads") = 0, py::arg("progress") = py::none(), py::arg("normals") = false,
          py::arg("seed") = 1, py::arg("precision") = "auto", py::arg("steps") = py::none(), py::arg("prior_steps") = py::none(),
          py::arg("resolution") = py::none(), py::arg("settings") = py::dict(),
          R"(Reconstruct a mesh from an unoriented point cloud.

points: (N, 3) float32 or float64 array, C-contiguous, finite.
preset: "default", "fast", "paper" or "scene". prior: path of a prior file from pcp_train /
train_prior (None: the preset's, the built-in prior fine-tuned on the cloud, or a self-prior trained
on it for "paper" and "scene"). threads: 0 = all cores. progress: None or a callable
(stage: str, step: int, total: int) -> bool | None; returning False cancels (pcp.Cancelled).
normals: also return the oriented normal of every input point. steps, prior_steps, resolution:
override the preset's query-network steps, self-prior steps and marching-cubes resolution.
settings: any other setting by its name, {"winding-near": 2, "smooth": True, "spreads": "0.5,1"}
(the names and ranges of pcp_reconstruct --list-settings; a bad value raises ValueError).
Returns (vertices (V, 3) float64, faces (F, 3) int32) in the input's frame, faces outward, and
with normals=True a third array (N, 3) of unit normals. Ctrl-C cancels (KeyboardInterrupt).)");
    m.def(
        "read_point_cloud",
        [](const std::string& path) {
            pcp::PointCloud c;
            {
                py::gil_scoped_release release;
                c = pcp::read_point_cloud(path);
            }
            return points_array(c.points);
        },
        py::arg("path"), "Points of a .ply, .xyz, .txt, .pts or .npy file as an (N, 3) float64 array.");
    m.def(
        "read_mesh",
        [](const std::string& path) {
            const pcp::Mesh mesh = pcp::read_mesh(path);
            return py::make_tuple(points_array(mesh.vertices), faces_array(mesh));
        },
        py::arg("path"), "(vertices, faces) of a .ply, .obj or .off mesh.");
    m.def(
        "write_mesh",
        [](const std::string& path, const py::handle& vertices, const py::handle& faces, bool ascii) {
            const pcp::Mesh mesh = to_mesh(vertices, faces, "mesh");
            pcp::MeshWriteOptions o;
            o.ascii = ascii;
            pcp::write_mesh(path, mesh, o);
        },
        py::arg("path"), py::arg("vertices"), py::arg("faces"), py::kw_only(), py::arg("ascii") = false,
        "Write a mesh (.ply, .obj, .off) atomically: no partial file on failure.");
    m.def("evaluate", &evaluate, py::arg("pred"), py::arg("gt"), py::kw_only(), py::arg("protocol") = "p2s",
          py::arg("samples") = 0, py::arg("seed") = 1, py::arg("floor") = false,
          "Metrics of pred = (vertices, faces) against gt = (vertices, faces): chamfer_l1, chamfer_l2, "
          "chamfer_l2_x100, normal_consistency, hausdorff, fscore {threshold: value}; protocol p2s, shapenet or scene.");
    m.def("train_prior", &train_prior, py::arg("clouds"), py::arg("output"), py::kw_only(), py::arg("preset") = "fast",
          py::arg("epochs") = py::none(), py::arg("steps") = py::none(), py::arg("threads") = 0, py::arg("seed") = 1,
          py::arg("precision") = "auto", py::arg("progress") = py::none(),
          "Train a local context prior on a list of (N, 3) arrays and write it to `output` (a file "
          "pcp_reconstruct --prior and reconstruct(prior=...) read). Returns {path, steps, final_loss}.");
}
