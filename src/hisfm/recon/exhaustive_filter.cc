#include "hisfm/recon/exhaustive_filter.h"

#include <algorithm>
#include <filesystem>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/recon/input_check.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {

void ExhaustiveFilterOptions::Check() const {
  HISFM_CHECK_OPTION(min_num_matches, min_num_matches >= 1, ">= 1");
  HISFM_CHECK_OPTION(verify_threshold,
                     verify_threshold >= 0.0 && verify_threshold <= 1.0,
                     "in [0.0, 1.0]");
  HISFM_CHECK_OPTION(batch_size, batch_size >= 1, ">= 1");
  communities.Check();
  verifier.Check();
}

nlohmann::json FilterPairsExhaustively(const std::string& database_path,
                                       const std::string& image_path,
                                       const std::string& output_database_path,
                                       const ExhaustiveFilterOptions& options) {
  options.Check();
  ThrowUnless(!std::filesystem::exists(output_database_path),
              StrCat("output database already exists: ",
                     output_database_path));
  Timer total;
  RequireValidDatabase(database_path);
  const Database database(database_path);
  const ViewGraph graph =
      ReadViewGraph(database, options.min_num_matches);
  ThrowUnless(graph.NumEdges() > 0,
              StrCat("database has no verified image pairs: ", database_path));
  const std::vector<DatabaseImage> images = database.ReadImages();
  CheckImagesUsable(database, images, graph);
  if (!image_path.empty()) CheckDirectoryExists(image_path, "image folder");
  const Communities communities =
      ComputeCommunities(graph, options.communities);
  VerifierContext context;
  context.database = &database;
  context.graph = &graph;
  context.communities = &communities;
  context.image_path = image_path;
  for (const DatabaseImage& im : images) {
    context.image_names[im.image_id] = im.name;
  }
  std::unique_ptr<BridgeScorer> scorer =
      CreateVerifier(options.verifier, context);

  LogHeading(StrCat("Scoring all ", graph.NumEdges(), " verified pairs with '",
                    scorer->Name(), "'"));
  Timer verify_timer;
  std::vector<ImagePair> keep;
  ProgressReporter progress("verifying pairs", graph.NumEdges());
  const size_t batch = static_cast<size_t>(options.batch_size);
  for (size_t start = 0; start < graph.NumEdges(); start += batch) {
    std::vector<ImagePair> pairs;
    for (size_t e = start; e < std::min(graph.NumEdges(), start + batch); ++e) {
      pairs.push_back(graph.Edges()[e].pair);
    }
    const std::vector<double> scores = scorer->Score(pairs);
    ThrowUnless(scores.size() == pairs.size(),
                "verifier returned a wrong number of scores");
    for (size_t k = 0; k < pairs.size(); ++k) {
      if (scores[k] >= options.verify_threshold) keep.push_back(pairs[k]);
    }
    progress.Update(start + pairs.size());
  }
  progress.Finish();
  const double verify_seconds = verify_timer.ElapsedSeconds();

  FilteredDatabaseOptions filter;
  filter.copy_descriptors = true;
  filter.copy_matches = true;
  WriteFilteredDatabase(database_path, output_database_path, keep, filter);
  HISFM_LOG_INFO("kept {} of {} pairs ({:.1f} s of verification)",
                 keep.size(), graph.NumEdges(), verify_seconds);
  return {{"verifier", scorer->Name()},
          {"verified_pairs", graph.NumEdges()},
          {"scored_pairs", graph.NumEdges()},
          {"kept_pairs", keep.size()},
          {"rejected_pairs", graph.NumEdges() - keep.size()},
          {"verify_seconds", verify_seconds},
          {"total_seconds", total.ElapsedSeconds()}};
}

}  // namespace hisfm
