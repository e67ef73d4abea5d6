#include "hisfm/python/python_results.h"

#include <pybind11/numpy.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <vector>

#include "hisfm/io/model.h"

namespace py = pybind11;

namespace hisfm {
namespace {

// True if numpy can be imported (looked up once).
bool HaveNumpy() {
  static const bool have = [] {
    try {
      py::module_::import("numpy");
      return true;
    } catch (const py::error_already_set&) {
      return false;
    }
  }();
  return have;
}

// `values` (row-major, `cols` columns; 0: one-dimensional) as a numpy array
// of T, or as (nested) lists without numpy.
template <typename T>
py::object Array(const std::vector<T>& values, size_t cols = 0) {
  const size_t rows = cols == 0 ? values.size() : values.size() / cols;
  if (!HaveNumpy()) {
    py::list out;
    for (size_t r = 0; r < rows; ++r) {
      if (cols == 0) {
        out.append(py::cast(values[r]));
        continue;
      }
      py::list row;
      for (size_t c = 0; c < cols; ++c) row.append(py::cast(values[r * cols + c]));
      out.append(row);
    }
    return out;
  }
  std::vector<py::ssize_t> shape = {static_cast<py::ssize_t>(rows)};
  if (cols > 0) shape.push_back(static_cast<py::ssize_t>(cols));
  py::array_t<T> array(shape);
  T* data = array.mutable_data();
  for (size_t i = 0; i < values.size(); ++i) data[i] = values[i];
  return std::move(array);
}

double NumberOrNaN(const nlohmann::json& value) {
  return value.is_number() ? value.get<double>()
                           : std::numeric_limits<double>::quiet_NaN();
}

// An edge list of HierarchyToJson as columns.
py::dict EdgeColumns(const nlohmann::json& edges) {
  std::vector<uint32_t> pairs, inliers, communities;
  std::vector<double> scores, cycle_errors;
  std::vector<int64_t> trees;
  py::list roles;
  const bool bridges = !edges.empty() && edges[0].contains("score");
  for (const nlohmann::json& e : edges) {
    pairs.push_back(e["image_id1"].get<uint32_t>());
    pairs.push_back(e["image_id2"].get<uint32_t>());
    inliers.push_back(e["inliers"].get<uint32_t>());
    if (!bridges) continue;
    communities.push_back(e["community1"].get<uint32_t>());
    communities.push_back(e["community2"].get<uint32_t>());
    scores.push_back(NumberOrNaN(e["score"]));
    cycle_errors.push_back(e.contains("cycle_error_deg")
                               ? NumberOrNaN(e["cycle_error_deg"])
                               : std::numeric_limits<double>::quiet_NaN());
    trees.push_back(e["tree"].is_number() ? e["tree"].get<int64_t>() : -1);
    roles.append(py::str(e["role"].get<std::string>()));
  }
  py::dict out;
  out["pairs"] = Array(pairs, 2);
  out["inliers"] = Array(inliers);
  if (bridges || edges.empty()) {
    out["communities"] = Array(communities, 2);
    out["scores"] = Array(scores);
    out["cycle_errors_deg"] = Array(cycle_errors);
    out["trees"] = Array(trees);
    out["roles"] = roles;
  }
  return out;
}

// The rejected trusted edges of a view_graph JSON as columns: `pairs` an
// (E, 2) array of image ids, `inliers`, `scores` and `rounds` arrays.
py::dict TrustedEdgeColumns(const nlohmann::json& edges) {
  std::vector<uint32_t> pairs, inliers;
  std::vector<double> scores;
  std::vector<int64_t> rounds;
  for (const nlohmann::json& e : edges) {
    pairs.push_back(e.at("image_id1").get<uint32_t>());
    pairs.push_back(e.at("image_id2").get<uint32_t>());
    inliers.push_back(e.at("inliers").get<uint32_t>());
    scores.push_back(NumberOrNaN(e.at("score")));
    rounds.push_back(e.at("round").get<int64_t>());
  }
  py::dict out;
  out["pairs"] = Array(pairs, 2);
  out["inliers"] = Array(inliers);
  out["scores"] = Array(scores);
  out["rounds"] = Array(rounds);
  return out;
}

// Converts the `per_image` lists of an evaluation in place.
void PerImageArrays(py::dict evaluation) {
  if (!evaluation.contains("per_image")) return;
  py::dict per_image = evaluation["per_image"].cast<py::dict>();
  for (const char* key : {"center_error", "rotation_error_deg"}) {
    std::vector<double> values;
    for (const py::handle v : per_image[key].cast<py::list>()) {
      values.push_back(v.is_none() ? std::numeric_limits<double>::quiet_NaN()
                                   : v.cast<double>());
    }
    per_image[key] = Array(values);
  }
}

// The poses of a model folder as columns.
py::dict Poses(const std::string& model_path) {
  const Reconstruction model = ReadModel(model_path);
  std::vector<uint32_t> ids;
  std::vector<double> rotations, translations, centers;
  py::list names;
  for (const auto& [image_id, image] : model.images) {
    ids.push_back(image_id);
    names.append(py::str(image.name));
    const Eigen::Quaterniond& q = image.cam_from_world.rotation;
    rotations.insert(rotations.end(), {q.w(), q.x(), q.y(), q.z()});
    const Eigen::Vector3d& t = image.cam_from_world.translation;
    translations.insert(translations.end(), {t.x(), t.y(), t.z()});
    const Eigen::Vector3d c = image.ProjectionCenter();
    centers.insert(centers.end(), {c.x(), c.y(), c.z()});
  }
  py::dict out;
  out["image_ids"] = Array(ids);
  out["names"] = names;
  out["rotations"] = Array(rotations, 4);
  out["translations"] = Array(translations, 3);
  out["centers"] = Array(centers, 3);
  return out;
}

}  // namespace

py::object JsonToPython(const nlohmann::json& value) {
  switch (value.type()) {
    case nlohmann::json::value_t::object: {
      py::dict out;
      for (const auto& [key, item] : value.items()) {
        out[py::str(key)] = JsonToPython(item);
      }
      return std::move(out);
    }
    case nlohmann::json::value_t::array: {
      py::list out;
      for (const nlohmann::json& item : value) out.append(JsonToPython(item));
      return std::move(out);
    }
    case nlohmann::json::value_t::string:
      return py::str(value.get<std::string>());
    case nlohmann::json::value_t::boolean:
      return py::bool_(value.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(value.get<int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(value.get<uint64_t>());
    case nlohmann::json::value_t::number_float:
      return py::float_(value.get<double>());
    default:
      return py::none();
  }
}

py::dict ViewGraphToPython(const nlohmann::json& view_graph) {
  py::dict out;
  for (const auto& [key, item] : view_graph.items()) {
    if (key == "images") {
      std::vector<uint32_t> ids;
      std::vector<int64_t> communities;
      std::vector<bool> skeletal_bits;
      py::list names;
      for (const nlohmann::json& image : item) {
        ids.push_back(image["image_id"].get<uint32_t>());
        names.append(py::str(image["name"].get<std::string>()));
        communities.push_back(image["community"].get<int64_t>());
        skeletal_bits.push_back(image["skeletal"].get<bool>());
      }
      out["image_ids"] = Array(ids);
      out["image_names"] = names;
      out["communities"] = Array(communities);
      std::vector<uint8_t> skeletal(skeletal_bits.begin(), skeletal_bits.end());
      py::object array = Array(skeletal);
      out["skeletal"] =
          HaveNumpy() ? array.attr("astype")(py::str("bool")) : array;
    } else if (key == "skeleton_bridges" || key == "rejected_bridges" ||
               key == "skeleton_intra_edges" || key == "leaf_edges" ||
               key == "support_edges") {
      out[py::str(key)] = EdgeColumns(item);
    } else if (key == "rejected_trusted_edges") {
      out[py::str(key)] = TrustedEdgeColumns(item);
    } else if (key == "isolated_images") {
      out[py::str(key)] = Array(item.get<std::vector<uint32_t>>());
    } else if (key == "components") {
      py::list components;
      for (const nlohmann::json& c : item) {
        py::dict component;
        component["images"] = Array(c["images"].get<std::vector<uint32_t>>());
        component["skeleton_images"] =
            Array(c["skeleton_images"].get<std::vector<uint32_t>>());
        component["num_edges"] = JsonToPython(c["num_edges"]);
        components.append(component);
      }
      out[py::str(key)] = components;
    } else {
      out[py::str(key)] = JsonToPython(item);
    }
  }
  return out;
}

py::dict MapperSummaryToPython(const nlohmann::json& summary,
                               const std::string& output_path) {
  py::dict out = JsonToPython(summary).cast<py::dict>();
  if (!out.contains("models")) return out;
  for (const py::handle model : out["models"].cast<py::list>()) {
    py::dict m = model.cast<py::dict>();
    const std::string folder =
        (std::filesystem::path(output_path) / m["path"].cast<std::string>())
            .string();
    m["poses"] = Poses(folder);
  }
  return out;
}

py::dict EvaluationToPython(const nlohmann::json& evaluation) {
  py::dict out = JsonToPython(evaluation).cast<py::dict>();
  if (out.contains("largest")) PerImageArrays(out["largest"].cast<py::dict>());
  if (out.contains("per_model")) {
    for (const py::handle model : out["per_model"].cast<py::list>()) {
      PerImageArrays(model.cast<py::dict>());
    }
  }
  return out;
}

}  // namespace hisfm
