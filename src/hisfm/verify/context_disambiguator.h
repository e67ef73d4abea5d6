// The coverage and distinctive-support bridge verifier (--HiSfM.verifier
// context; the builtin default is the multi-view test, multiview_verifier.h):
// a two-view / hierarchy-context disambiguator that needs no learned
// weights, no images and no network.
//
// Idea (missing correspondences, Zach, Irschara, Bischof, "What can missing
// correspondences tell us about 3D structure and motion?", CVPR 2008; Cui &
// Tan, "Global Structure-from-Motion by Similarity Averaging", ICCV 2015):
// a doppelganger pair matches only the repeated structure, so the unique
// content around it, which a true pair of the same views would also match,
// stays unmatched. We measure this at the level of image cells: the content
// of image x that is matchable at all is what x's trusted neighbours match
// (its strongest intra-community pairs, which the HiSfM hierarchy already
// trusts, Sec. III-A/B of the HiSfM paper). For a bridge (i, j),
//   relative_x = |cells of x holding bridge inliers| /
//                |cells of x holding inliers of x's reference pair|,
// for x in {i, j}, and the bridge's relative coverage is the smaller one. The
// reference makes the score self-calibrating: it adapts to each image's
// texture, resolution and matcher density, so no threshold depends on the
// scene.
//   score = min(1, relative / (2 * min_relative_coverage)),
// so a bridge at exactly min_relative_coverage scores 0.5, the skeleton
// builder's default threshold.
//
// Measurements behind the defaults: docs/decisions.md (2026-11).
//
// Second cue, distinctive support (track_consistency.h; Snavely et al.,
// Photo Tourism, SIGGRAPH 2006; Wilson & Snavely, ICCV 2013): inliers whose
// feature tracks hold two keypoints of one image lie on structure repeated
// within a photo and cannot tell which copy a pair sees. A bridge whose
// fraction of distinctive inliers is far below the fraction its images show
// over all their pairs matches only such structure:
//   distinctive_score = min(1, ratio / (2 * min_distinctive_ratio)),
// silent (1) unless the shortfall is significant (Poisson tail below
// distinctive_significance). The bridge's score is the smaller of the two.
//
// Limits: a doppelganger that fills both images (a whole symmetric facade)
// with repetition never seen twice in one photo leaves nothing to miss and
// no inconsistent track, and is accepted; a true bridge that overlaps its
// images far less than their trusted neighbours do is rejected (the
// skeleton then takes a later bridge). Pairs whose unique matches are true
// and repeated ones false, and doppelgangers that are an image's strongest
// pair (and so shape its community), are left to pair_filter.h, which runs
// before the hierarchy.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "hisfm/graph/bridge_scorer.h"
#include "hisfm/graph/communities.h"
#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/verify/inlier_coverage.h"
#include "hisfm/verify/track_consistency.h"
#include "hisfm/verify/verifier_context.h"

namespace hisfm {

struct DisambiguatorOptions {
  /// Cells along the longer image side of the square occupancy grid on which
  /// inlier coverage is counted (10 on a 1067x800 image: cells of ~107 px).
  int grid_cells = 10;
  /// Number of an image's strongest intra-community pairs whose largest
  /// coverage is the image's reference coverage (1 = its top-1 pair, the
  /// pair that formed its community).
  int num_reference_pairs = 1;
  /// Relative coverage that scores exactly 0.5. Bridges explaining less of
  /// an image than this fraction of what its trusted neighbour explains
  /// score below 0.5.
  double min_relative_coverage = 0.6;
  /// Distinctive-inlier ratio (track_consistency.h) that scores exactly 0.5:
  /// a bridge whose fraction of distinctive inliers is below this fraction
  /// of the fraction its images show elsewhere scores below 0.5. 0 disables
  /// the cue.
  double min_distinctive_ratio = 0.5;
  /// The distinctive cue speaks only if the bridge's shortfall of
  /// distinctive inliers is significant at this level (Poisson tail,
  /// DistinctiveSupport::p_value); otherwise it is silent (score 1).
  double distinctive_significance = 0.01;
  /// Memory for what the tracks' read records of every bridge (coverage
  /// cell counts and the keypoints its inliers use, keypoint_multisets.h),
  /// in MiB. With it a bridge is scored without reading its inliers again;
  /// the bridges beyond the budget are read one by one when Kruskal asks
  /// for them. About 150 MB on the densely matched 5,000-image synthetic
  /// street (948k bridges). Without the distinctive cue there is no tracks'
  /// read, and a read of the bridges alone records them at the first one.
  double max_scan_memory_mb = 1024;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// Everything the disambiguator measured on one bridge (for logs and tests).
struct BridgeEvidence {
  ImagePair pair;
  uint32_t num_inliers = 0;
  /// Cells holding bridge inliers, in image_id1 and image_id2.
  int cells1 = 0;
  int cells2 = 0;
  /// Reference cell counts of the two images.
  double reference1 = 0;
  double reference2 = 0;
  /// cells / reference, per image, capped at 1.
  double relative1 = 0;
  double relative2 = 0;
  /// min(relative1, relative2).
  double relative = 0;
  /// min(1, relative / (2 min_relative_coverage)).
  double coverage_score = 0;
  /// Inliers on consistent tracks (track_consistency.h).
  uint32_t num_distinctive = 0;
  /// Smaller distinctive fraction of the two images' matched keypoints.
  double image_distinctive_fraction = 0;
  /// (num_distinctive / num_inliers) / image_distinctive_fraction, capped
  /// at 1; 1 when the cue is silent.
  double distinctive_ratio = 1;
  /// Poisson tail probability of the shortfall (1 without one).
  double distinctive_p_value = 1;
  /// min(1, distinctive_ratio / (2 min_distinctive_ratio)).
  double distinctive_score = 1;
  /// The score in [0, 1]: min(coverage_score, distinctive_score).
  double score = 0;
};

/// The context BridgeScorer (Name() "context"). Per-image work (keypoint
/// cells, reference coverage) is computed once and cached. At the first
/// bridge the tracks of the whole graph are joined (one read of every
/// pair's inliers, in pair-id order), and the same read records each
/// bridge's coverage cells and the keypoints its inliers use
/// (max_scan_memory_mb); from then on a bridge's score costs no read and
/// about a microsecond, however many bridges Kruskal asks for (86% of them
/// on the densely matched 5,000-image synthetic street, whose heavy bridges
/// are mostly doppelgangers). The scores equal those computed from the
/// bridge's inliers (Evaluate). The disambiguator holds a read transaction
/// on the database while it lives.
class ContextDisambiguator : public BridgeScorer {
 public:
  /// The database, graph and communities must outlive the disambiguator.
  ContextDisambiguator(const Database& database, const ViewGraph& graph,
                       const Communities& communities,
                       const DisambiguatorOptions& options = {});
  /// Same, from the hierarchy's verifier context (database, graph and
  /// communities must be set).
  explicit ContextDisambiguator(const VerifierContext& context,
                                const DisambiguatorOptions& options = {});

  ~ContextDisambiguator() override;

  std::string Name() const override { return "context"; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override;

  /// Measures one pair from its inliers, read from the database (any two
  /// images with a stored two-view geometry; throws hisfm::Error if the
  /// pair is not in the database).
  BridgeEvidence Evaluate(const ImagePair& pair);

  /// Reference cell count of an image (cached).
  double ReferenceCells(ImageId image_id);

  /// Bridges scored from what the tracks' read recorded, and bridges whose
  /// inliers were read to score them.
  size_t NumScoredFromScan() const { return num_scored_from_scan_; }
  size_t NumScoredByReading() const { return num_scored_by_reading_; }

 private:
  struct ImageCache {
    bool has_reference = false;
    double reference_cells = 0;
    bool reference_done = false;
    // The reference a bridge divides by (with the scene fallback, at least
    // 1), set by Prepare; 0 until then.
    double bridge_reference = 0;
  };
  // What the tracks' read recorded of one bridge.
  struct ScanRecord {
    bool recorded = false;
    uint32_t num_inliers = 0;
    int cells1 = 0;
    int cells2 = 0;
    // The keypoints of image_id1 its inliers use: entry of bridge_keypoints_.
    size_t keypoints = 0;
  };

  double SceneReferenceFraction();
  const TrackConsistency& Tracks();
  // Computes (serially) the per-image data a bridge of `pair` needs.
  void Prepare(const ImagePair& pair);
  // The graph's edges across communities, in pair-id order (cached).
  const std::vector<ImagePair>& Bridges();
  // Index of `pair` in Bridges(), or Bridges().size().
  size_t BridgeIndex(const ImagePair& pair);
  // Called with each pair's inliers during a read (on the reading thread).
  using PairObserver = std::function<void(const ImagePair&, FeatureMatchSpan)>;
  // Records the bridges once: during the tracks' read, or without the
  // distinctive cue in a read of the bridges alone.
  void RecordBridges();
  // Records every bridge that a read meets, within max_scan_memory_mb:
  // `read` is given two observers, one for the reading thread (coverage
  // cells) and one for the caller's (keypoint multisets).
  void RecordDuring(
      const std::function<void(const PairObserver&, const PairObserver&)>&
          read);
  // Measures a prepared pair from its inlier matches (oriented as stored).
  BridgeEvidence MeasureInliers(const ImagePair& pair,
                                FeatureMatchSpan inliers);
  // Measures a prepared bridge from its record.
  BridgeEvidence MeasureRecord(const ImagePair& pair, const ScanRecord& r);
  // The evidence of a prepared pair (oriented as stored) from its inlier
  // and cell counts and, if the distinctive cue is on and it has inliers,
  // its distinctive support.
  BridgeEvidence Combine(const ImagePair& pair, uint32_t num_inliers,
                         int cells1, int cells2,
                         const std::optional<DistinctiveSupport>& support)
      const;

  const Database& database_;
  const ViewGraph& graph_;
  const Communities& communities_;
  DisambiguatorOptions options_;
  CoverageGrid grid_;
  std::unordered_map<ImageId, ImageCache> cache_;
  double scene_reference_fraction_ = -1;
  std::unique_ptr<TrackConsistency> tracks_;
  // One read transaction for all the reads of the disambiguator's lifetime.
  Database::ReadScope read_scope_;
  CoverageGrid::Scratch scratch_;
  // The graph's bridges, listed when first needed.
  std::optional<std::vector<ImagePair>> bridges_;
  // By bridge index: what the tracks' read recorded.
  std::vector<ScanRecord> records_;
  bool records_done_ = false;
  KeypointMultisets bridge_keypoints_;
  size_t num_scored_from_scan_ = 0;
  size_t num_scored_by_reading_ = 0;
};

}  // namespace hisfm
