// hisfm's results as Python values: JSON documents as dicts and lists, and
// the columns that are natural as numpy arrays (image ids, communities,
// edges, poses, per-image errors) as arrays. Without numpy, arrays come back
// as lists.
#pragma once

#include <pybind11/pybind11.h>

#include <nlohmann/json.hpp>
#include <string>

namespace hisfm {

/// A JSON value as the same Python value (dict, list, str, int, float, bool,
/// None).
pybind11::object JsonToPython(const nlohmann::json& value);

/// The view graph of ComputeViewGraphJson: as JSON, but the image records
/// become columns (`image_ids`, `image_names`, `communities`, `skeletal`) and
/// every edge list a dict of columns (`pairs` an (E, 2) array of image ids,
/// `inliers`; for bridges also `communities` (E, 2), `scores` (NaN: not
/// scored), `roles`, `trees`, `cycle_errors_deg` (NaN: no cycle checked)).
pybind11::dict ViewGraphToPython(const nlohmann::json& view_graph);

/// The summary of RunHierarchicalMapper, each model with its `poses` read
/// from output_path/<path>: `image_ids`, `names`, `rotations` (N, 4 as w, x,
/// y, z of cam_from_world), `translations` (N, 3) and `centers` (N, 3).
pybind11::dict MapperSummaryToPython(const nlohmann::json& summary,
                                     const std::string& output_path);

/// An evaluation (ToJson of MultiModelEvaluation) with each `per_image`
/// error list as a float array (NaN where undefined).
pybind11::dict EvaluationToPython(const nlohmann::json& evaluation);

}  // namespace hisfm
