// Feature extraction and matching as Slurm job arrays (`hisfm reconstruct
// --executor slurm`), on a filesystem shared with the cluster:
//   - extraction: the image list is cut into shards; each task runs colmap
//     feature_extractor on its shard into a database of its own; the shards
//     are merged into one database, image ids in name order, cameras as one
//     feature_extractor run over the whole list makes them
//     (io/database_merge.h);
//   - matching: the candidate pairs are cut into blocks; each task copies
//     the features database and runs colmap matches_importer on its block's
//     pair list (exhaustive and sequential matching; the sequential pairs are
//     those of colmap's sequential_matcher), or colmap vocab_tree_matcher on
//     its shard of query images (retrieval); the blocks' matches and
//     two-view geometries are merged into a copy of the features database.
// The tasks of both stages live in WORKSPACE/slurm/{features,matching}/ and
// are resumable (slurm_executor.h): a rerun submits only the shards and
// blocks that are missing. Every task copies the features database once, so
// the shared filesystem carries blocks x its size.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "hisfm/recon/colmap_runner.h"
#include "hisfm/recon/slurm_executor.h"

namespace hisfm {

/// Index pairs (i < j) of images in name order.
using IndexPairs = std::vector<std::pair<size_t, size_t>>;

/// Every pair of `num_images` images, cut into blocks: the images form
/// groups of `group_size` consecutive images and block (a, b), a <= b, holds
/// the pairs between groups a and b (within group a if a == b). Empty
/// blocks are left out.
std::vector<IndexPairs> ExhaustivePairBlocks(size_t num_images,
                                             size_t group_size);

/// The pairs colmap's sequential_matcher (COLMAP 3.8, without loop
/// detection) matches among `num_images` images in name order: each image
/// with the next `overlap` images and, if `quadratic_overlap`, with the
/// images 2^k further (k = 0 .. overlap - 1). Sorted, without repeats.
IndexPairs SequentialPairs(size_t num_images, size_t overlap,
                           bool quadratic_overlap);

/// Cuts `pairs` into blocks of at most `block_pairs` pairs, in order.
std::vector<IndexPairs> CutPairs(const IndexPairs& pairs, size_t block_pairs);

/// Size of the pieces of `count` items so that there are about `pieces`
/// pieces (at least 1 item each).
size_t PieceSize(size_t count, size_t pieces);

/// What the extraction tasks run.
struct SlurmExtractionJob {
  /// Absolute image folder and image names (colmap's, in name order).
  std::string image_path;
  std::vector<std::string> image_names;
  /// Images per shard (> 0).
  size_t shard_size = 0;
  /// One camera for all images (merged into one), else one per image.
  bool single_camera = true;
  std::string camera_model = "SIMPLE_RADIAL";
  /// Further feature_extractor arguments.
  std::vector<std::string> extractor_args;
  /// Fingerprint of the stage's inputs (each shard adds its list).
  std::string fingerprint;
};

/// Runs the extraction shards from `array_dir` and merges them into
/// `output_path` (written under a temporary name and renamed). Returns the
/// number of shards.
size_t ExtractFeaturesOnSlurm(const SlurmExtractionJob& job,
                              const ColmapRunnerOptions& colmap,
                              const SlurmOptions& slurm,
                              const std::string& array_dir,
                              const std::string& output_path);

/// What the matching tasks run.
struct SlurmMatchingJob {
  /// A database with the features and no matches; every task copies it.
  std::string features_path;
  /// Image names by index (image id - 1 in the features database).
  std::vector<std::string> image_names;
  /// Pair blocks, for colmap matches_importer (used if not empty).
  std::vector<IndexPairs> pair_blocks;
  /// Query images of each vocab_tree_matcher task (used if pair_blocks is
  /// empty), with the tree and the number of retrieved images.
  std::vector<std::vector<size_t>> query_shards;
  std::string vocab_tree_path;
  int num_neighbors = 0;
  /// Further --SiftMatching.* arguments of the matchers.
  std::vector<std::string> matcher_args;
  /// Fingerprint of the stage's inputs (each task adds its list).
  std::string fingerprint;
};

/// Runs the matching tasks from `array_dir` and merges their matches into a
/// copy of the features database at `output_path` (written under a
/// temporary name and renamed). Returns the number of tasks.
size_t MatchOnSlurm(const SlurmMatchingJob& job,
                    const ColmapRunnerOptions& colmap,
                    const SlurmOptions& slurm, const std::string& array_dir,
                    const std::string& output_path);

}  // namespace hisfm
