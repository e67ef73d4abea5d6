// The Python module `hisfm`: the view graph, the mapper and the evaluation
// of the `hisfm` command, with options as keyword arguments named like its
// flags without their prefix (`top_k=1` for --HiSfM.top_k), parsed through
// the same flags (hisfm/cli). Errors are raised with hisfm's one-line
// message: hisfm.Error (a RuntimeError) for bad input, TypeError for an
// unknown keyword, ValueError for a value its flag cannot take,
// KeyboardInterrupt when Ctrl-C stopped the work (and colmap).
#include <pybind11/pybind11.h>

#include <CLI/CLI.hpp>
#include <string>
#include <utility>
#include <vector>

#include "hisfm/cli/keyword_options.h"
#include "hisfm/cli/option_flags.h"
#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/io/model.h"
#include "hisfm/python/python_results.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/report/report_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"

namespace py = pybind11;

namespace hisfm {
namespace {

using Keywords = std::vector<std::pair<std::string, std::string>>;

// A keyword argument's value as the text its flag parses. None leaves the
// option at its default.
bool KeywordText(const std::string& name, const py::handle value,
                 std::string* text) {
  if (value.is_none()) return false;
  if (py::isinstance<py::bool_>(value)) {
    *text = value.cast<bool>() ? "true" : "false";
  } else if (py::isinstance<py::int_>(value) ||
             py::hasattr(value, "__index__")) {
    // Python ints and numpy's integers.
    *text = py::repr(py::int_(py::reinterpret_borrow<py::object>(value))).cast<std::string>();
  } else if (py::isinstance<py::float_>(value) ||
             py::hasattr(value, "__float__")) {
    *text = py::repr(py::float_(py::reinterpret_borrow<py::object>(value))).cast<std::string>();
  } else if (py::isinstance<py::str>(value)) {
    *text = value.cast<std::string>();
  } else if (py::hasattr(value, "__fspath__")) {
    *text = py::module_::import("os").attr("fspath")(value).cast<std::string>();
  } else {
    throw BadKeywordValue(StrCat(
        "option '", name, "' takes a number, a string, a bool or a path, not ",
        py::str(py::type::handle_of(value).attr("__name__")).cast<std::string>()));
  }
  return true;
}

// The keyword arguments but `skip`, as keyword and text.
Keywords KeywordArguments(const py::kwargs& kwargs,
                          const std::string& skip = "") {
  Keywords out;
  for (const auto& [key, value] : kwargs) {
    const std::string name = key.cast<std::string>();
    std::string text;
    if (name != skip && KeywordText(name, value, &text)) {
      out.emplace_back(name, text);
    }
  }
  return out;
}

// A path argument (str or os.PathLike) as text.
std::string PathText(const std::string& name, const py::handle value) {
  std::string text;
  if (!KeywordText(name, value, &text)) {
    throw BadKeywordValue(StrCat(name, " must not be None"));
  }
  return text;
}

py::dict ViewGraphFunction(const py::object& database_path, const py::kwargs& kwargs) {
  CLI::App app("hisfm.view_graph");
  std::string image_path, log_level = "info";
  HierarchicalMapperOptions options;
  app.add_option("--image_path", image_path,
                 "Folder of the photos (for verifiers that read them)");
  AddHierarchicalMapperFlags(app, &options);
  AddLogLevelFlag(app, &log_level);
  ParseKeywords(app, KeywordArguments(kwargs));
  CheckMapperOptions(options);
  const std::string database = PathText("database_path", database_path);
  nlohmann::json view_graph;
  {
    py::gil_scoped_release release;
    InterruptScope interrupt_scope;
    view_graph = ComputeViewGraphJson(database, image_path, options);
    ThrowIfInterrupted();
  }
  return ViewGraphToPython(view_graph);
}

py::dict MapperFunction(const py::object& database_path, const py::object& image_path,
                const py::object& output_path, const py::kwargs& kwargs) {
  CLI::App app("hisfm.mapper");
  MapperPaths paths;
  HierarchicalMapperOptions options;
  std::string log_level = "info";
  AddMapperPathFlags(app, &paths);
  PrepareMapperCommand(app, &options, &log_level);
  Keywords keywords = {
      {"database_path", PathText("database_path", database_path)},
      {"image_path", PathText("image_path", image_path)},
      {"output_path", PathText("output_path", output_path)}};
  for (auto& keyword : KeywordArguments(kwargs, "mapper_options")) {
    keywords.push_back(std::move(keyword));
  }
  ParseKeywords(app, keywords);
  // colmap mapper's own options: mapper_options={"ba_global_max_num_iterations": 30}.
  std::vector<std::string> pass_through;
  if (kwargs.contains("mapper_options") && !kwargs["mapper_options"].is_none()) {
    if (!py::isinstance<py::dict>(kwargs["mapper_options"])) {
      throw BadKeywordValue(
          "mapper_options must be a dict of colmap mapper options");
    }
    for (const auto& [key, value] : kwargs["mapper_options"].cast<py::dict>()) {
      const std::string name = key.cast<std::string>();
      std::string text;
      if (!KeywordText(name, value, &text)) continue;
      pass_through.push_back("--Mapper." + name);
      pass_through.push_back(text);
    }
  }
  options.mapper_args = TakeMapperPassThrough(pass_through);
  CheckMapperOptions(options);
  paths.options_record = OptionsRecord(app, options.mapper_args);
  nlohmann::json summary;
  {
    py::gil_scoped_release release;
    InterruptScope interrupt_scope;
    summary = RunHierarchicalMapper(paths, options);
    const std::string report_path = paths.output_path + "/report.html";
    WriteReport(ReadMapperReportInput(paths.output_path), report_path);
    HISFM_LOG_INFO("report: {}", report_path);
    ThrowIfInterrupted();
  }
  return MapperSummaryToPython(summary, paths.output_path);
}

py::dict EvaluateFunction(const py::object& model_path, const py::object& reference_path,
                  const py::kwargs& kwargs) {
  CLI::App app("hisfm.evaluate");
  PoseEvaluationOptions options;
  OptionFlagMap flags;
  AddPoseEvaluationFlags(app, &options, &flags);
  ParseKeywords(app, KeywordArguments(kwargs));
  CheckOptionFlags(flags, [&] { options.Check(); });
  const std::string model = PathText("model_path", model_path);
  const std::string reference_folder =
      PathText("reference_path", reference_path);
  nlohmann::json out;
  {
    py::gil_scoped_release release;
    const std::vector<std::string> model_paths = ResultModelFolders(model);
    std::vector<Reconstruction> models;
    for (const std::string& path : model_paths) {
      models.push_back(ReadModel(path));
    }
    const Reconstruction reference = ReadModel(reference_folder);
    ThrowUnless(!reference.images.empty(),
                StrCat("reference model has no images: ", reference_folder));
    out = ToJson(EvaluateModels(models, reference, options));
    out["reference_path"] = reference_folder;
    out["model_paths"] = model_paths;
  }
  return EvaluationToPython(out);
}

}  // namespace
}  // namespace hisfm

PYBIND11_MODULE(hisfm, m) {
  using namespace hisfm;
  m.doc() =
      "HiSfM: hierarchical, disambiguating structure-from-motion on COLMAP "
      "databases. Options are keyword arguments named like the flags of the "
      "`hisfm` command without their prefix (top_k=1 for --HiSfM.top_k).";
  m.attr("__version__") = HISFM_VERSION;
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const UnknownKeyword& e) {
      PyErr_SetString(PyExc_TypeError, e.what());
    } catch (const BadKeywordValue& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const Interrupted& e) {
      PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
    } catch (const Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });
  m.def("view_graph", &ViewGraphFunction, py::arg("database_path"),
        "view_graph(database_path, **options) -> dict\n\n"
        "The hierarchy of a COLMAP database (`hisfm view_graph`): "
        "communities, verified skeleton, leaves. image_ids, communities and "
        "skeletal are arrays per image; each edge list is a dict of columns "
        "with `pairs` an (E, 2) array of image ids. Options: image_path and "
        "the --HiSfM.* flags (top_k, verify_threshold, verifier, ...), "
        "log_level.");
  m.def("mapper", &MapperFunction, py::arg("database_path"), py::arg("image_path"),
        py::arg("output_path"),
        "mapper(database_path, image_path, output_path, **options) -> dict\n\n"
        "Runs `hisfm mapper`: models in output_path/0, 1, ..., the summary "
        "(returned, each model with its poses as arrays), report.html. "
        "Options: work_path, the --HiSfM.* flags, colmap_path, log_level, "
        "and mapper_options, a dict of colmap mapper options "
        "({'ba_global_max_num_iterations': 30} for "
        "--Mapper.ba_global_max_num_iterations).");
  m.def("evaluate", &EvaluateFunction, py::arg("model_path"), py::arg("reference_path"),
        "evaluate(model_path, reference_path, **options) -> dict\n\n"
        "Gauge-free pose evaluation (`hisfm evaluate --json`), with the "
        "per-image errors as arrays. Options: verdict_threshold_deg, "
        "min_correct_pair_fraction, center_threshold, "
        "min_correct_center_fraction, require_all_registered, "
        "min_model_size, alignment_inlier_threshold.");
}
