#include "hisfm/verify/multiview_verifier.h"

#include <algorithm>
#include <cmath>

#include "hisfm/util/error.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/parallel.h"
#include "hisfm/verify/match_burstiness.h"

namespace hisfm {

void MultiViewVerifierOptions::Check() const {
  geometry.Check();
  local_model.Check();
  edge_test.Check();
  HISFM_CHECK_OPTION(other_side_ratio,
                     other_side_ratio >= 0.0 && other_side_ratio <= 1.0,
                     "in [0.0, 1.0]");
  HISFM_CHECK_OPTION(num_threads, num_threads >= 0, ">= 0");
}

MultiViewVerifier::MultiViewVerifier(const Database& database,
                                     const ViewGraph& graph,
                                     const MultiViewVerifierOptions& options)
    : options_(options),
      cache_(database, graph, options.geometry) {
  options_.Check();
  KeypointDegrees degrees = ComputeKeypointDegrees(database, graph);
  ranking_ = options_.rank_by_burstiness
                 ? ReweightedGraph(graph,
                                   BurstinessWeights(database, graph, degrees))
                 : graph;
  cache_.SetKeypointDegrees(std::move(degrees));
}

const LocalModel& MultiViewVerifier::EgoModel(ImageId ego, ImageId other) {
  const size_t count = options_.local_model.num_candidates;
  std::vector<ImageId> candidates =
      SideNeighbours(ranking_, ego, other, count, options_.other_side_ratio);
  auto key = std::make_pair(ego, std::move(candidates));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = models_.find(key);
    if (it != models_.end()) return it->second;
  }
  LocalModel model =
      BuildEgoModelFrom(cache_, ego, key.second, options_.local_model);
  std::lock_guard<std::mutex> lock(mutex_);
  return models_.emplace(std::move(key), std::move(model)).first->second;
}

const EdgeEvidence* MultiViewVerifier::FindEvidence(
    const ImagePair& pair) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = evidence_.find(pair);
  return it == evidence_.end() ? nullptr : &it->second;
}

const EdgeEvidence& MultiViewVerifier::Evaluate(const ImagePair& pair) {
  return EvaluatePair(pair, /*parallel_models=*/true);
}

const EdgeEvidence& MultiViewVerifier::EvaluatePair(const ImagePair& pair,
                                                    bool parallel_models) {
  if (const EdgeEvidence* known = FindEvidence(pair)) return *known;
  // Verification can take minutes on large scenes: Ctrl-C stops it here.
  ThrowIfInterrupted();
  const ImageId i = pair.image_id1;
  const ImageId j = pair.image_id2;
  const LocalModel* models[2] = {nullptr, nullptr};
  ParallelFor(2, parallel_models ? options_.num_threads : 1, [&](size_t s) {
    models[s] = s == 0 ? &EgoModel(i, j) : &EgoModel(j, i);
  });
  EdgeEvidence evidence =
      TestEdge(cache_, *models[0], *models[1], i, j, options_.edge_test);
  std::lock_guard<std::mutex> lock(mutex_);
  return evidence_.emplace(pair, std::move(evidence)).first->second;
}

namespace {

// An edge's weight relative to the strongest edge of each of its images (the
// smaller of the two ratios).
double RelativeWeight(const ViewGraph& graph, const ImagePair& pair) {
  const double w = graph.Weight(pair.image_id1, pair.image_id2);
  double ratio = 1;
  for (const ImageId id : {pair.image_id1, pair.image_id2}) {
    const std::vector<size_t> best = StrongestEdges(graph, graph.IndexOf(id), 1);
    if (!best.empty() && graph.Edges()[best[0]].weight > 0) {
      ratio = std::min(ratio, w / graph.Edges()[best[0]].weight);
    }
  }
  return ratio;
}

// The share of a pair's inliers that its evidence marks consistent (1 if
// the pair was not judged or has no inliers).
double ShareOf(const EdgeEvidence& evidence) {
  if (!evidence.judged || evidence.consistent.empty()) return 1.0;
  return static_cast<double>(evidence.num_consistent) /
         static_cast<double>(evidence.consistent.size());
}

}  // namespace

PairFeatures MultiViewVerifier::Features(const ImagePair& pair) {
  return FeaturesOf(pair, /*parallel_models=*/true);
}

PairFeatures MultiViewVerifier::FeaturesOf(const ImagePair& pair,
                                           bool parallel_models) {
  PairFeatures f =
      PairFeatures::FromEvidence(EvaluatePair(pair, parallel_models));
  f.relative_burstiness = RelativeWeight(ranking_, pair);
  return f;
}

double MultiViewVerifier::ScoreOf(const ImagePair& pair) {
  return CalibratedPairScore(Features(pair));
}

bool MultiViewVerifier::RelativeRotation(ImageId from, ImageId to,
                                         Eigen::Quaterniond* to_from_from) {
  const ImagePair pair(from, to);
  const std::shared_ptr<const PairGeometry> geometry =
      cache_.Pair(pair.image_id1, pair.image_id2);
  if (geometry->hypotheses.empty()) return false;
  size_t h = 0;
  const EdgeEvidence* evidence = FindEvidence(pair);
  if (evidence && evidence->hypothesis >= 0) {
    h = static_cast<size_t>(evidence->hypothesis);
  }
  // The geometry is oriented from the smaller id to the larger.
  const Eigen::Quaterniond r2_from_r1 =
      geometry->hypotheses[h].cam2_from_cam1.rotation;
  *to_from_from = from == pair.image_id1 ? r2_from_r1 : r2_from_r1.inverse();
  return true;
}

double MultiViewVerifier::CycleRotationErrorDeg(
    const std::vector<ImageId>& cycle) {
  if (cycle.size() < 2) return -1.0;
  Eigen::Quaterniond total = Eigen::Quaterniond::Identity();
  for (size_t k = 0; k < cycle.size(); ++k) {
    const ImageId from = cycle[k];
    const ImageId to = cycle[(k + 1) % cycle.size()];
    Eigen::Quaterniond step;
    if (!cache_.HasPair(from, to) || !RelativeRotation(from, to, &step)) {
      return -1.0;
    }
    total = step * total;
  }
  return total.normalized().angularDistance(Eigen::Quaterniond::Identity()) *
         180.0 / M_PI;
}

std::vector<double> MultiViewVerifier::PerPair(
    const std::vector<ImagePair>& pairs,
    const std::function<double(const ImagePair&, bool)>& value) {
  // Each pair on one thread; a lone pair builds its two models in parallel
  // instead.
  const bool parallel_models = pairs.size() == 1;
  std::vector<double> values(pairs.size());
  ParallelFor(pairs.size(), options_.num_threads, [&](size_t k) {
    values[k] = value(pairs[k], parallel_models);
  });
  return values;
}

std::vector<double> MultiViewVerifier::Score(
    const std::vector<ImagePair>& pairs) {
  return PerPair(pairs, [this](const ImagePair& pair, bool parallel_models) {
    return CalibratedPairScore(FeaturesOf(pair, parallel_models));
  });
}

std::vector<FeatureMatch> MultiViewVerifier::ConsistentInliers(
    const ImagePair& pair) {
  const EdgeEvidence& evidence = Evaluate(pair);
  const std::shared_ptr<const PairGeometry> geometry =
      cache_.Pair(pair.image_id1, pair.image_id2);
  if (!evidence.judged) return geometry->matches;
  std::vector<FeatureMatch> out;
  for (size_t k = 0; k < geometry->matches.size(); ++k) {
    if (evidence.consistent[k]) out.push_back(geometry->matches[k]);
  }
  return out;
}

double MultiViewVerifier::ConsistentShare(const ImagePair& pair) {
  return ShareOf(Evaluate(pair));
}

std::vector<double> MultiViewVerifier::ConsistentShares(
    const std::vector<ImagePair>& pairs) {
  return PerPair(pairs, [this](const ImagePair& pair, bool parallel_models) {
    return ShareOf(EvaluatePair(pair, parallel_models));
  });
}

}  // namespace hisfm
