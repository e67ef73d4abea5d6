#include "hisfm/recon/sequence_pass.h"

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <set>
#include <unordered_map>
#include <unordered_set>

#include "hisfm/io/database.h"
#include "hisfm/util/error.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/parallel.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/timer.h"
#include "hisfm/verify/unique_points.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {

namespace fs = std::filesystem;

void SequencePassOptions::Check() const {
  HISFM_CHECK_OPTION(near_join_window, near_join_window >= 0, ">= 0");
  HISFM_CHECK_OPTION(chain_segment_images,
                     chain_segment_images == 0 || chain_segment_images >= 3,
                     "0 or >= 3");
  HISFM_CHECK_OPTION(chain_segment_overlap,
                     chain_segment_images == 0 ||
                         (chain_segment_overlap >= 1 &&
                          chain_segment_overlap < chain_segment_images),
                     "in [1, chain_segment_images)");
  HISFM_CHECK_OPTION(chain_segment_parallel_runs,
                     chain_segment_parallel_runs >= 1, ">= 1");
  sequence.Check();
  segment_merge.Check();
  agreement.Check();
  unique_points.Check();
  conflict_join.Check();
  join.Check();
  near_join.Check();
  HISFM_CHECK_OPTION(loop_closure_max_hypotheses,
                     loop_closure_max_hypotheses >= 1, ">= 1");
  HISFM_CHECK_OPTION(
      loop_closure_max_rotation_deg,
      loop_closure_max_rotation_deg >= 0 && loop_closure_max_rotation_deg <= 180,
      "in [0, 180]");
}

nlohmann::json SequencePassResult::ToJson() const {
  return {{"applies", chain.applies},
          {"consecutive_share", chain.consecutive_share},
          {"z_score", chain.z_score},
          {"links", chain.links.size()},
          {"breaks", chain.num_breaks},
          {"ran", ran},
          {"segments", num_segments},
          {"models", num_models},
          {"joined", num_joined},
          {"joined_near", num_joined_near},
          {"joined_by_conflict", num_joined_by_conflict},
          {"loop_closures_kept", num_loop_closures},
          {"registered", num_registered},
          {"pairs_inside_models", num_judged},
          {"pairs_removed", num_removed},
          {"matches_removed", num_matches_removed},
          {"note", note},
          {"seconds", seconds}};
}

namespace {

// The inlier matches of `pairs` (those in the database), by ascending pair
// id.
std::vector<PairMatches> ReadPairMatches(const Database& database,
                                         const std::vector<ImagePair>& pairs) {
  std::vector<PairMatches> out;
  out.reserve(pairs.size());
  database.ForEachInlierMatches(
      pairs, [&](const ImagePair& pair, FeatureMatchSpan matches) {
        out.push_back(
            {pair, std::vector<FeatureMatch>(matches.begin(), matches.end())});
      });
  return out;
}

// The inlier matches of the pairs of `candidates` with one image in `a` and
// the other in `b`.
std::vector<PairMatches> PairsAcross(const Database& database,
                                     const std::vector<ImagePair>& candidates,
                                     const Reconstruction& a,
                                     const Reconstruction& b) {
  std::vector<ImagePair> across;
  for (const ImagePair& p : candidates) {
    if ((a.images.count(p.image_id1) && b.images.count(p.image_id2)) ||
        (b.images.count(p.image_id1) && a.images.count(p.image_id2))) {
      across.push_back(p);
    }
  }
  return ReadPairMatches(database, across);
}

// The base, then the models of `rest` not joined into it.
std::vector<Reconstruction> LeftModels(Reconstruction base,
                                       std::vector<Reconstruction> rest,
                                       const std::vector<bool>& joined) {
  std::vector<Reconstruction> left;
  left.push_back(std::move(base));
  for (size_t i = 0; i < rest.size(); ++i) {
    if (!joined[i]) left.push_back(std::move(rest[i]));
  }
  return left;
}

// Joins the models into the largest while any join succeeds; returns the
// models left (the largest, grown, first) and counts the joins. Three rounds,
// each for the models the rounds before left apart: through the near pairs
// of the chain (near_join_window), through all the pairs, and by the
// conflict of proposed joins with their unique points (join_by_conflict).
std::vector<Reconstruction> JoinChainModels(const Database& database,
                                            const ViewGraph& graph,
                                            const SequenceChain& chain,
                                            std::vector<Reconstruction> models,
                                            const SequencePassOptions& options,
                                            SequencePassResult* result) {
  if (models.empty()) return models;
  std::swap(models[0], models[LargestModelIndex(models)]);
  Reconstruction base = std::move(models[0]);
  std::vector<Reconstruction> rest(std::make_move_iterator(models.begin() + 1),
                                   std::make_move_iterator(models.end()));
  std::vector<bool> joined(rest.size(), false);
  // The pairs between the base and rest[i], read once for each size of the
  // base (a join grows it): both rounds of joins look at the same pairs.
  std::vector<std::vector<PairMatches>> across(rest.size());
  std::vector<size_t> across_base_images(rest.size(), 0);
  const std::vector<ImagePair> pairs = graph.Pairs();
  auto pairs_across = [&](size_t i) -> const std::vector<PairMatches>& {
    if (across_base_images[i] != base.NumRegImages()) {
      across[i] = PairsAcross(database, pairs, base, rest[i]);
      across_base_images[i] = base.NumRegImages();
    }
    return across[i];
  };
  // Joins what it can, rest[i] by `join(i)`, until no join succeeds.
  auto join_all = [&](auto&& join) {
    size_t count = 0;
    for (bool progress = true; progress;) {
      progress = false;
      for (size_t i = 0; i < rest.size(); ++i) {
        if (joined[i] || !join(i)) continue;
        joined[i] = true;
        across[i] = {};
        progress = true;
        ++count;
      }
    }
    return count;
  };
  // Joins rest[i] through `across` under `merge`; `kind` names the pairs.
  auto join_through = [&](size_t i, const std::vector<PairMatches>& across,
                          const ModelMergeOptions& merge, const char* kind) {
    if (across.empty()) return false;
    const ModelMergeStep step =
        MergeThroughMatches(rest[i], across, merge, &base);
    HISFM_LOG_INFO(
        "sequence: {} a chain model of {} images through {} {}pair(s): {} of "
        "{} matched points agree",
        step.merged ? "joined" : "could not join", step.num_images,
        step.num_pairs, kind, step.num_inliers, step.num_correspondences);
    return step.merged;
  };
  const std::vector<ImagePair> near =
      NearChainPairs(chain, pairs, options.near_join_window);
  const size_t near_count = join_all([&](size_t i) {
    return join_through(i, PairsAcross(database, near, base, rest[i]),
                        options.near_join, "near ");
  });
  result->num_joined += near_count;
  result->num_joined_near += near_count;
  result->num_joined += join_all([&](size_t i) {
    return join_through(i, pairs_across(i), options.join, "");
  });
  if (!options.join_by_conflict ||
      std::find(joined.begin(), joined.end(), false) == joined.end()) {
    return LeftModels(std::move(base), std::move(rest), joined);
  }
  std::vector<std::unordered_set<Point3DId>> confusing(rest.size());
  for (size_t i = 0; i < rest.size(); ++i) {
    if (!joined[i]) {
      confusing[i] = FindConfusingPoints(database, pairs, rest[i],
                                         options.unique_points);
    }
  }
  std::unordered_set<Point3DId> base_confusing;
  size_t base_images = 0;  // the base's size when base_confusing was found
  const size_t count = join_all([&](size_t i) {
    if (base_images != base.NumRegImages()) {
      base_confusing =
          FindConfusingPoints(database, pairs, base, options.unique_points);
      base_images = base.NumRegImages();
    }
    const ConflictJoinStep step = JoinByLeastConflict(
        rest[i], pairs_across(i), base_confusing, confusing[i],
        options.conflict_join, options.join, &base);
    HISFM_LOG_INFO(
        "sequence: {} a chain model of {} images by conflict: {} pairs "
        "propose joins, {} examined; the best has {} voting pairs, whose "
        "photos match {} of the {} unique points it predicts (the next best "
        "{:.1f}%)",
        step.merge.merged ? "joined" : "could not join",
        step.merge.num_images, step.num_fitted_pairs, step.num_hypotheses,
        step.num_votes, step.num_found, step.num_expected,
        100.0 * step.next_found_share);
    return step.merge.merged;
  });
  result->num_joined += count;
  result->num_joined_by_conflict += count;
  return LeftModels(std::move(base), std::move(rest), joined);
}

// The pairs of `rejected` (pairs inside `model` that the transfer test
// rejected) that close a loop of the chain: the voting pairs of the join of
// the model's first half in the chain's order onto its second half that
// conflicts least with their unique points, when it stands out; none
// otherwise.
std::vector<ImagePair> LoopClosures(const Database& database,
                                    const std::vector<ImagePair>& pairs,
                                    const SequenceChain& chain,
                                    const Reconstruction& model,
                                    const std::vector<ImagePair>& rejected,
                                    const SequencePassOptions& options) {
  std::unordered_map<ImageId, size_t> position;
  for (size_t i = 0; i < chain.order.size(); ++i) {
    position[chain.order[i]] = i;
  }
  std::vector<std::pair<size_t, ImageId>> held;
  for (const auto& [id, image] : model.images) {
    const auto it = position.find(id);
    if (it != position.end()) held.push_back({it->second, id});
  }
  if (held.size() < 2) return {};
  std::sort(held.begin(), held.end());
  // The model's images in the first half of its order: those placed before
  // the middle one's place.
  const size_t middle = held[held.size() / 2].first;
  std::set<ImageId> first, second;
  for (const auto& [place, id] : held) {
    (place < middle ? first : second).insert(id);
  }
  // Pairs within the break test's window are the chain's own neighbours,
  // not closures of a loop.
  const size_t window = static_cast<size_t>(options.sequence.break_window);
  std::vector<ImagePair> across;
  for (const ImagePair& p : rejected) {
    const auto a = position.find(p.image_id1);
    const auto b = position.find(p.image_id2);
    if (a == position.end() || b == position.end()) continue;
    const size_t lo = std::min(a->second, b->second);
    const size_t hi = std::max(a->second, b->second);
    if (hi - lo > window && lo < middle && hi >= middle) across.push_back(p);
  }
  if (across.empty()) return {};
  Reconstruction first_half = model;
  RemoveImages(second, &first_half);
  Reconstruction second_half = model;
  RemoveImages(first, &second_half);
  const std::vector<PairMatches> matches = ReadPairMatches(database, across);
  ConflictJoinOptions bars = options.conflict_join;
  bars.max_hypotheses = options.loop_closure_max_hypotheses;
  // Confusing points are found inside each half: in the whole model the
  // closures themselves tie the clutter they match to its drifted copies
  // (on block_loop_1000_s2 the closures' join then found 22 of 382 unique
  // points, against 335 of 862 this way).
  const LeastConflictJoin best = FindLeastConflictJoin(
      first_half, second_half, matches,
      FindConfusingPoints(database, pairs, first_half, options.unique_points),
      FindConfusingPoints(database, pairs, second_half,
                          options.unique_points),
      bars, options.join.max_relative_error);
  const ConflictJoinStep& step = best.step;
  const double rotation_deg =
      best.model_from_other.rotation.angularDistance(
          Eigen::Quaterniond::Identity()) *
      180.0 / M_PI;
  const bool keep = best.stands_out &&
                    rotation_deg <= options.loop_closure_max_rotation_deg;
  HISFM_LOG_INFO(
      "sequence: loop closure: {} rejected pairs across the halves of the "
      "order, {} propose joins, {} examined; the best has {} voting pairs, "
      "whose photos match {} of the {} unique points it predicts (the next "
      "best {:.1f}%), and turns one half by {:.1f} degrees: {}",
      across.size(), step.num_fitted_pairs, step.num_hypotheses,
      step.num_votes, step.num_found, step.num_expected,
      100.0 * step.next_found_share, rotation_deg,
      keep ? "kept as closures" : "none kept");
  if (!keep) return {};
  std::vector<ImagePair> closures;
  for (const size_t k : best.voting_pairs) closures.push_back(matches[k].pair);
  return closures;
}

// The chain's models: its segments (ChainSegments) reconstructed
// (chain_segment_parallel_runs at a time, each from a database of its links
// alone, removed after its run), their models merged through the images they
// share, the largest first, then the others without the images of those
// before them. Throws hisfm::Error when every segment's reconstruction
// throws.
std::vector<Reconstruction> ReconstructChain(
    const std::string& database_path, const SequenceChain& chain,
    const std::string& work_path, const ChainReconstructor& reconstruct,
    const SequencePassOptions& options, SequencePassResult* result) {
  const std::vector<std::vector<ImagePair>> segments =
      ChainSegments(chain, static_cast<size_t>(options.chain_segment_images),
                    static_cast<size_t>(options.chain_segment_overlap));
  result->num_segments = segments.size();
  std::vector<std::vector<Reconstruction>> segment_models(segments.size());
  std::vector<std::string> errors(segments.size());
  std::mutex copy_mutex;
  ParallelFor(
      segments.size(), options.chain_segment_parallel_runs, [&](size_t j) {
        ThrowIfInterrupted();
        if (segments.size() > 1) {
          HISFM_LOG_INFO(
              "sequence: chain segment {}/{}: {} links (the run "
              "sees the other images of the chain as isolated)",
              j + 1, segments.size(), segments[j].size());
        }
        const std::string chain_db = StrCat(work_path, "/chain_", j, ".db");
        std::error_code ec;
        fs::remove(chain_db, ec);
        {
          std::lock_guard<std::mutex> lock(copy_mutex);
          WriteFilteredDatabase(database_path, chain_db, segments[j]);
        }
        try {
          segment_models[j] = reconstruct(chain_db);
        } catch (const Interrupted&) {
          throw;
        } catch (const Error& e) {
          errors[j] = e.what();
        }
        fs::remove(chain_db, ec);
      });
  std::vector<Reconstruction> models;
  std::string last_error;
  bool any_reconstructed = false;
  for (size_t j = 0; j < segments.size(); ++j) {
    if (!errors[j].empty()) {
      // The other segments may still join around it.
      if (segments.size() > 1) {
        HISFM_LOG_WARN("sequence: chain segment {}/{} gave no model ({})",
                       j + 1, segments.size(), errors[j]);
      }
      last_error = errors[j];
      continue;
    }
    any_reconstructed = true;
    for (Reconstruction& m : segment_models[j]) models.push_back(std::move(m));
  }
  ThrowUnless(any_reconstructed || segments.empty(), last_error);
  if (segments.size() <= 1 || models.empty()) return models;
  std::vector<Reconstruction> merged;
  while (!models.empty()) {
    ModelMergeResult r = MergeModels(models, options.segment_merge);
    std::vector<Reconstruction> left = UnmergedModels(models, r);
    merged.push_back(std::move(r.model));
    models = std::move(left);
  }
  std::sort(merged.begin(), merged.end(),
            [](const Reconstruction& a, const Reconstruction& b) {
              return a.NumRegImages() > b.NumRegImages();
            });
  std::vector<Reconstruction> out;
  out.push_back(std::move(merged[0]));
  merged.erase(merged.begin());
  for (Reconstruction& m : DisjointModels(out[0], std::move(merged), 2)) {
    out.push_back(std::move(m));
  }
  HISFM_LOG_INFO(
      "sequence: the {} segments' models merged into {} model(s), "
      "the largest of {} images",
      segments.size(), out.size(), out[0].NumRegImages());
  return out;
}

// Joins the chain's models, judges every pair inside them and writes the
// cleaned database; fills the result's counts and path. Returns false (and
// sets the note) when require_one_model finds several models left.
bool CleanPairs(const Database& database, const std::string& database_path,
                const ViewGraph& graph, const std::string& work_path,
                const SequencePassOptions& options,
                std::vector<Reconstruction>* models,
                SequencePassResult* result) {
  *models = JoinChainModels(database, graph, result->chain,
                            std::move(*models), options, result);
  if (options.require_one_model && models->size() > 1) {
    result->note = StrCat("the chain's ", models->size(),
                          " pieces could not be joined into one model");
    return false;
  }
  // Pairs inside a model keep their agreeing matches or go (those with too
  // few testable matches too: the chain holds both images and gives no
  // reason to trust them); the others stay as they are.
  const std::vector<ImagePair> pairs = graph.Pairs();
  std::unordered_map<ImagePair, std::vector<FeatureMatch>, ImagePairHash>
      cleaned;
  std::set<ImagePair> removed;
  for (const Reconstruction& model : *models) {
    result->num_registered += model.NumRegImages();
    std::vector<ImagePair> rejected;
    for (PairAgreement& a :
         JudgePairsAgainstModel(database, pairs, model, options.agreement)) {
      ++result->num_judged;
      const size_t before = graph.Weight(a.pair.image_id1, a.pair.image_id2);
      if (!a.agrees) {
        removed.insert(a.pair);
        rejected.push_back(a.pair);
        result->num_matches_removed += before;
        continue;
      }
      result->num_matches_removed += before - a.agreeing_matches.size();
      cleaned[a.pair] = std::move(a.agreeing_matches);
    }
    if (!options.close_loops_by_conflict) continue;
    // Closures keep their input matches.
    for (const ImagePair& p : LoopClosures(database, pairs, result->chain,
                                           model, rejected, options)) {
      removed.erase(p);
      result->num_matches_removed -= graph.Weight(p.image_id1, p.image_id2);
      ++result->num_loop_closures;
      result->loop_closures.push_back(p);
    }
  }
  result->num_removed = removed.size();
  std::vector<ImagePair> keep;
  for (const ImagePair& pair : pairs) {
    if (!removed.count(pair)) keep.push_back(pair);
  }
  FilteredDatabaseOptions write;
  write.replace_inliers = &cleaned;
  const std::string cleaned_path = work_path + "/cleaned.db";
  std::error_code ec;
  fs::remove(cleaned_path, ec);
  WriteFilteredDatabase(database_path, cleaned_path, keep, write);
  result->cleaned_database_path = cleaned_path;
  return true;
}

}  // namespace

SequencePassResult RunSequencePass(const std::string& database_path,
                                   int min_num_matches,
                                   const std::string& work_path,
                                   const ChainReconstructor& reconstruct,
                                   const SequencePassOptions& options) {
  options.Check();
  Timer timer;
  SequencePassResult result;
  const Database database(database_path);
  const ViewGraph graph = ReadViewGraph(database, min_num_matches);
  result.num_input_pairs = graph.NumEdges();
  std::unordered_map<ImageId, std::string> names;
  for (const DatabaseImage& im : database.ReadImages()) {
    names[im.image_id] = im.name;
  }
  result.chain = FindSequenceChain(graph, names, options.sequence);
  const SequenceChain& chain = result.chain;
  HISFM_LOG_INFO(
      "name order: {:.0f}% of consecutive names verified, z = {:.1f}: {}",
      100.0 * chain.consecutive_share, chain.z_score,
      chain.applies ? "a capture sequence" : "not used");
  auto stop = [&](const std::string& note) {
    result.note = note;
    result.seconds = timer.ElapsedSeconds();
    return result;
  };
  if (!chain.applies) {
    return stop(options.sequence.mode == "off" ? "off"
                                               : "names give no sequence");
  }
  if (chain.links.empty()) return stop("no chain link");
  HISFM_LOG_INFO("chain: {} links, {} breaks", chain.links.size(),
                 chain.num_breaks);
  std::error_code ec;
  fs::create_directories(work_path, ec);
  ThrowUnless(!ec, StrCat("cannot create ", work_path, ": ", ec.message()));
  std::vector<Reconstruction> models;
  try {
    models = ReconstructChain(database_path, chain, work_path, reconstruct,
                              options, &result);
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    HISFM_LOG_WARN("sequence: the chain could not be reconstructed ({}); "
                   "no pair removed",
                   e.what());
    return stop(StrCat("the chain could not be reconstructed: ", e.what()));
  }
  result.num_models = models.size();
  // Whatever fails from here leaves the input as it is, as a failing chain
  // does: the mapper goes on without the pass.
  try {
    if (!CleanPairs(database, database_path, graph, work_path, options,
                    &models, &result)) {
      HISFM_LOG_WARN("sequence: {}; no pair removed", result.note);
      return stop(result.note);
    }
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    HISFM_LOG_WARN("sequence: the pairs could not be checked ({}); no pair "
                   "removed",
                   e.what());
    result.cleaned_database_path.clear();
    result.num_registered = result.num_judged = result.num_removed = 0;
    result.num_matches_removed = 0;
    return stop(StrCat("the pairs could not be checked: ", e.what()));
  }
  result.chain_models = std::move(models);
  result.ran = true;
  result.seconds = timer.ElapsedSeconds();
  HISFM_LOG_INFO(
      "sequence: {} chain model(s) ({} joined), {} images; {} pairs inside "
      "them: {} removed, {} kept as loop closures, {} of their inlier "
      "matches dropped ({:.2f} s)",
      result.num_models, result.num_joined, result.num_registered,
      result.num_judged, result.num_removed, result.num_loop_closures,
      result.num_matches_removed, result.seconds);
  return result;
}

}  // namespace hisfm
