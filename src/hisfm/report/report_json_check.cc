#include "hisfm/report/report_json_check.h"

#include <initializer_list>
#include <utility>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

using Json = nlohmann::json;

enum class Kind { kNumber, kString, kBool, kObject, kArray };

const char* KindName(Kind kind) {
  switch (kind) {
    case Kind::kNumber:
      return "a number";
    case Kind::kString:
      return "a string";
    case Kind::kBool:
      return "true or false";
    case Kind::kObject:
      return "an object";
    case Kind::kArray:
      return "an array";
  }
  return "";
}

bool IsKind(const Json& j, Kind kind) {
  switch (kind) {
    case Kind::kNumber:
      return j.is_number();
    case Kind::kString:
      return j.is_string();
    case Kind::kBool:
      return j.is_boolean();
    case Kind::kObject:
      return j.is_object();
    case Kind::kArray:
      return j.is_array();
  }
  return false;
}

std::string Problem(const std::string& field, const Json& j, Kind kind) {
  std::string found = j.dump();
  if (found.size() > 40) found = found.substr(0, 37) + "...";
  return StrCat("'", field, "' should be ", KindName(kind), ", not ", found);
}

// The first field of `fields` that object `j` has with another type (null
// allowed if `null_ok`); `prefix` names `j`.
std::string CheckFields(
    const Json& j, const std::string& prefix,
    std::initializer_list<std::pair<const char*, Kind>> fields, bool null_ok) {
  for (const auto& [key, kind] : fields) {
    if (!j.contains(key)) continue;
    const Json& value = j.at(key);
    if ((null_ok && value.is_null()) || IsKind(value, kind)) continue;
    return Problem(prefix + key, value, kind);
  }
  return "";
}

// Checks that `j[key]`, if present, is an array of objects with `fields`.
std::string CheckArrayOfObjects(
    const Json& j, const char* key,
    std::initializer_list<std::pair<const char*, Kind>> fields, bool null_ok) {
  if (!j.contains(key)) return "";
  const Json& array = j.at(key);
  if (!array.is_array()) return Problem(key, array, Kind::kArray);
  for (size_t i = 0; i < array.size(); ++i) {
    const std::string name = StrCat(key, "[", i, "]");
    if (!array[i].is_object()) return Problem(name, array[i], Kind::kObject);
    const std::string problem =
        CheckFields(array[i], name + ".", fields, null_ok);
    if (!problem.empty()) return problem;
  }
  return "";
}

}  // namespace

std::string FindSummaryJsonProblem(const Json& summary) {
  if (!summary.is_object())
    return Problem("(the file)", summary, Kind::kObject);
  constexpr Kind kNumber = Kind::kNumber;
  std::string problem = CheckFields(summary, "",
                                    {{"images", kNumber},
                                     {"verified_pairs", kNumber},
                                     {"pairs_after_filter", kNumber},
                                     {"communities", kNumber},
                                     {"candidate_bridges", kNumber},
                                     {"num_trees", kNumber},
                                     {"skeleton_bridges", kNumber},
                                     {"rejected_bridges", kNumber},
                                     {"skeleton_images", kNumber},
                                     {"skeleton_edges", kNumber},
                                     {"leaf_edges", kNumber},
                                     {"hierarchy_edges", kNumber},
                                     {"verifier", Kind::kString},
                                     {"verifier_calls", kNumber},
                                     {"verifier_batches", kNumber},
                                     {"verified_fraction", kNumber},
                                     {"components", kNumber},
                                     {"isolated_images", kNumber},
                                     {"database_path", Kind::kString},
                                     {"image_path", Kind::kString},
                                     {"work_path", Kind::kString},
                                     {"registered_images", kNumber},
                                     {"points3D", kNumber},
                                     {"mean_reprojection_error", kNumber},
                                     {"mean_track_length", kNumber},
                                     {"timings", Kind::kObject}},
                                    /*null_ok=*/true);
  if (!problem.empty()) return problem;
  problem = CheckArrayOfObjects(summary, "models",
                                {{"path", Kind::kString},
                                 {"registered_images", kNumber},
                                 {"points3D", kNumber},
                                 {"observations", kNumber},
                                 {"mean_track_length", kNumber},
                                 {"mean_reprojection_error", kNumber},
                                 {"component_images", kNumber},
                                 {"scaffold_images", kNumber},
                                 {"scaffold_registered", kNumber}},
                                /*null_ok=*/true);
  if (!problem.empty()) return problem;
  if (summary.contains("timings") && summary.at("timings").is_object()) {
    for (const auto& [key, value] : summary.at("timings").items()) {
      if (!value.is_number()) {
        return Problem("timings." + key, value, Kind::kNumber);
      }
    }
  }
  return "";
}

std::string FindHierarchyJsonProblem(const Json& hierarchy) {
  if (!hierarchy.is_object()) {
    return Problem("(the file)", hierarchy, Kind::kObject);
  }
  std::string problem =
      CheckFields(hierarchy, "", {{"num_communities", Kind::kNumber}},
                  /*null_ok=*/false);
  if (!problem.empty()) return problem;
  problem = CheckArrayOfObjects(hierarchy, "images",
                                {{"image_id", Kind::kNumber},
                                 {"name", Kind::kString},
                                 {"community", Kind::kNumber},
                                 {"skeletal", Kind::kBool}},
                                /*null_ok=*/false);
  if (!problem.empty()) return problem;
  for (const char* key : {"skeleton_bridges", "rejected_bridges",
                          "skeleton_intra_edges", "leaf_edges"}) {
    problem = CheckArrayOfObjects(hierarchy, key,
                                  {{"image_id1", Kind::kNumber},
                                   {"image_id2", Kind::kNumber},
                                   {"inliers", Kind::kNumber},
                                   {"community1", Kind::kNumber},
                                   {"community2", Kind::kNumber},
                                   {"tree", Kind::kNumber},
                                   {"role", Kind::kString}},
                                  /*null_ok=*/false);
    if (!problem.empty()) return problem;
  }
  return "";
}

}  // namespace hisfm
