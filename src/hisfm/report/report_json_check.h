// Type checks of the JSON files a report reads back from a mapper run
// (hisfm_summary.json and the work folder's view_graph.json), so that a
// file edited or written by another version fails with a message naming the
// file and the field instead of a JSON library exception.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace hisfm {

/// The first field of a mapper summary (RunHierarchicalMapper's
/// hisfm_summary.json) whose type the report cannot use, as
/// "'models[0].path' is a number, not a string"; "" if there is none.
/// Missing fields are fine (the report shows a dash).
std::string FindSummaryJsonProblem(const nlohmann::json& summary);

/// The same for a hierarchy (HierarchyToJson, view_graph.json).
std::string FindHierarchyJsonProblem(const nlohmann::json& hierarchy);

}  // namespace hisfm
