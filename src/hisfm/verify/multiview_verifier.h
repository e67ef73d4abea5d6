// HiSfM's built-in disambiguator: the multi-view edge test
// (edge_consistency.h) on ego models (local_model.h), with every model,
// pose and verdict computed once.
//
// It needs no learned weights, no photos and no network: only the keypoints,
// inlier matches and cameras of the COLMAP database. It judges any pair the
// hierarchy asks about: bridges for the skeleton (as a BridgeScorer), and the
// strongest pairs that the hierarchy trusts without verification (top-1
// community edges, leaf and intra-community edges, paper Sec. III-A and
// III-C). Its score is calibrated (see ScoreOf): a pair scoring s is true
// about s of the time on the tuning half of the synthetic families, so that
// one threshold (--HiSfM.verify_threshold) means the same for every
// verifier.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "hisfm/graph/bridge_scorer.h"
#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/verify/edge_consistency.h"
#include "hisfm/verify/geometry_cache.h"
#include "hisfm/verify/local_model.h"
#include "hisfm/verify/pair_score.h"

namespace hisfm {

struct MultiViewVerifierOptions {
  GeometryCacheOptions geometry;
  LocalModelOptions local_model;
  EdgeTestOptions edge_test;
  /// Rank each image's neighbours for its ego model by burstiness-weighted
  /// support (match_burstiness.h) instead of inlier count: in a street of
  /// identical facades the strongest pairs by inliers are often
  /// doppelgangers.
  bool rank_by_burstiness = true;
  /// Build the two ego models of a tested pair on their own sides
  /// (SideNeighbours in local_model.h): each image's model leaves out the
  /// neighbours x with w(ego, x) < other_side_ratio * w(other, x), by the
  /// ranking weights. 0: each model only leaves out the other image.
  double other_side_ratio = 0.5;
  /// Threads that judge pairs (0 = one per core): the pairs of a batch
  /// (Score) in parallel, and a lone pair's two ego models in parallel.
  /// Scores do not depend on it.
  int num_threads = 0;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// The built-in verifier (Name() "builtin"). Its methods may be called from
/// several threads at once, provided nothing else uses its database
/// meanwhile (geometry_cache.h). A pair's score does not depend on which
/// pairs were judged before it; RelativeRotation and CycleRotationErrorDeg
/// do (they use an evaluated pair's accepted hypothesis).
class MultiViewVerifier : public BridgeScorer {
 public:
  /// `graph` holds every verified pair (it names the pairs that exist and
  /// orders each image's neighbours for its ego models). The database and
  /// the graph must outlive the verifier.
  MultiViewVerifier(const Database& database, const ViewGraph& graph,
                    const MultiViewVerifierOptions& options = {});

  std::string Name() const override { return "builtin"; }
  /// Scores the pairs on up to num_threads threads.
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override;

  /// The evidence on a pair (computed once; `pair` must be an edge).
  const EdgeEvidence& Evaluate(const ImagePair& pair);
  /// The features of a pair (its evidence and relative supports).
  PairFeatures Features(const ImagePair& pair);
  /// The calibrated score of a pair (pair_score.h), in (0, 1).
  double ScoreOf(const ImagePair& pair);
  /// Composes the relative rotations of the cycle's pairs (each the
  /// hypothesis its edge test accepted, else the best-supported one);
  /// negative if a pair has no pose.
  double CycleRotationErrorDeg(const std::vector<ImageId>& cycle) override;
  /// The relative rotation to_from_from of an edge: the hypothesis its edge
  /// test joined by if the pair was evaluated, else the best-supported one;
  /// false if the pair has no pose.
  bool RelativeRotation(ImageId from, ImageId to, Eigen::Quaterniond* to_from_from);
  /// The ego model of `ego` for the test of the pair (ego, other): built on
  /// ego's side of the pair (SideNeighbours with other_side_ratio; ratio 0:
  /// only without `other`), computed once per list of candidate
  /// neighbours.
  const LocalModel& EgoModel(ImageId ego, ImageId other);
  /// The pair's inlier matches (oriented as stored: the smaller image id's
  /// keypoints first) that agree with the geometry its test accepted; all
  /// of them if the test could not judge it.
  std::vector<FeatureMatch> ConsistentInliers(const ImagePair& pair);
  /// ConsistentInliers' share of the pair's inliers (1 if the pair has
  /// none or its test could not judge it).
  double ConsistentShare(const ImagePair& pair) override;
  /// ConsistentShare of each pair, the pairs judged on up to num_threads
  /// threads (as Score).
  std::vector<double> ConsistentShares(
      const std::vector<ImagePair>& pairs) override;

  GeometryCache& cache() { return cache_; }
  /// The graph by which ego models rank neighbours (burstiness weights when
  /// rank_by_burstiness, else the input graph).
  const ViewGraph& RankingGraph() const { return ranking_; }
  /// Pairs evaluated so far.
  size_t NumEvaluated() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return evidence_.size();
  }

 private:
  // Evaluate(), building the two ego models on two threads when
  // `parallel_models` (and num_threads allows).
  const EdgeEvidence& EvaluatePair(const ImagePair& pair,
                                   bool parallel_models);
  // value(pair, parallel_models) of each pair, the pairs on up to
  // num_threads threads (a lone pair with parallel_models, so that its two
  // ego models are built in parallel instead).
  std::vector<double> PerPair(
      const std::vector<ImagePair>& pairs,
      const std::function<double(const ImagePair&, bool)>& value);
  // Features(), with EvaluatePair's `parallel_models`.
  PairFeatures FeaturesOf(const ImagePair& pair, bool parallel_models);
  // The evidence of a pair evaluated before, else null.
  const EdgeEvidence* FindEvidence(const ImagePair& pair) const;

  MultiViewVerifierOptions options_;
  // The graph by which ego models rank neighbours.
  ViewGraph ranking_;
  GeometryCache cache_;
  // Ego models by ego image and candidate neighbours.
  std::map<std::pair<ImageId, std::vector<ImageId>>, LocalModel> models_;
  std::map<ImagePair, EdgeEvidence> evidence_;
  // Guards models_ and evidence_ (std::map: what they hold never moves, so
  // references to it stay valid). Models and evidence are computed outside
  // the lock; when two threads compute the same one, the first stored is
  // kept (both are the same).
  mutable std::mutex mutex_;
};

}  // namespace hisfm
