#include "hisfm/verify/multiview_verifier.h"

#include <algorithm>
#include <cmath>

#include "hisfm/util/error.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/verify/match_burstiness.h"

namespace hisfm {

void MultiViewVerifierOptions::Check() const {
  geometry.Check();
  local_model.Check();
  edge_test.Check();
  HISFM_CHECK_OPTION(other_side_ratio,
                     other_side_ratio >= 0.0 && other_side_ratio <= 1.0,
                     "in [0.0, 1.0]");
}

MultiViewVerifier::MultiViewVerifier(const Database& database,
                                     const ViewGraph& graph,
                                     const MultiViewVerifierOptions& options)
    : graph_(graph),
      options_(options),
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
  auto it = models_.find(key);
  if (it != models_.end()) return it->second;
  LocalModel model =
      BuildEgoModelFrom(cache_, ego, key.second, options_.local_model);
  return models_.emplace(std::move(key), std::move(model)).first->second;
}

const EdgeEvidence& MultiViewVerifier::Evaluate(const ImagePair& pair) {
  auto it = evidence_.find(pair);
  if (it != evidence_.end()) return it->second;
  // Verification can take minutes on large scenes: Ctrl-C stops it here.
  ThrowIfInterrupted();
  const ImageId i = pair.image_id1;
  const ImageId j = pair.image_id2;
  const LocalModel& model_i = EgoModel(i, j);
  const LocalModel& model_j = EgoModel(j, i);
  return evidence_
      .emplace(pair,
               TestEdge(cache_, model_i, model_j, i, j, options_.edge_test))
      .first->second;
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

}  // namespace

PairFeatures MultiViewVerifier::Features(const ImagePair& pair) {
  PairFeatures f = PairFeatures::FromEvidence(Evaluate(pair));
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
  const auto it = evidence_.find(pair);
  if (it != evidence_.end() && it->second.hypothesis >= 0) {
    h = static_cast<size_t>(it->second.hypothesis);
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

std::vector<double> MultiViewVerifier::Score(
    const std::vector<ImagePair>& pairs) {
  std::vector<double> scores;
  scores.reserve(pairs.size());
  for (const ImagePair& p : pairs) scores.push_back(ScoreOf(p));
  return scores;
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

}  // namespace hisfm
