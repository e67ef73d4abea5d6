// Merging COLMAP databases written in pieces, e.g. by the jobs of a cluster:
// feature databases of disjoint image shards into one database with the
// image ids of a single run, and matching databases of pair blocks into the
// features database they were copied from.
#pragma once

#include <string>
#include <vector>

namespace hisfm {

struct FeatureShardMergeOptions {
  /// true: every image gets the first camera of the shard holding the first
  /// image (what `colmap feature_extractor --ImageReader.single_camera 1`
  /// does on the whole collection); false (default): every camera of the
  /// shards is kept, re-keyed in the order of the images using it.
  bool single_camera = false;

  void Check() const {}
};

/// Writes a new COLMAP database at `output_path` holding the cameras,
/// images, keypoints and descriptors of the shard databases, whose images
/// must be `image_names` exactly (each in one shard). Image i of
/// `image_names` gets image id i + 1 (one `colmap feature_extractor` run
/// over the list numbers images in the order their extraction finishes,
/// which varies with threads; the merge's order does not); camera ids
/// follow the same order. Columns are copied
/// by name (those of COLMAP 3.8's schema that a shard has). The shards are
/// opened read-only; the output is written to a temporary file and renamed
/// into place. Throws hisfm::Error naming the shard and the image if an image
/// is missing, in two shards, not in the list, or has no keypoints.
void MergeFeatureShards(const std::vector<std::string>& shard_paths,
                        const std::vector<std::string>& image_names,
                        const std::string& output_path,
                        const FeatureShardMergeOptions& options = {});

/// What MergeMatchBlocks copied.
struct MatchBlockMergeStats {
  /// Rows of matches and two_view_geometries in the output.
  size_t matched_pairs = 0;
  size_t verified_pairs = 0;
  /// Rows found in more than one block (the first block's is kept).
  size_t duplicate_pairs = 0;
};

/// Writes a new COLMAP database at `output_path`: the cameras, images,
/// keypoints and descriptors of `features_path`, and the matches and
/// two_view_geometries of every block database. Each block must be a copy
/// of the features database (same image ids and names: checked) that a
/// matcher added rows to. A pair found in several blocks keeps the first
/// block's rows. Inputs are opened read-only; the output is written to a
/// temporary file and renamed into place. Throws hisfm::Error naming the
/// block on a mismatch.
MatchBlockMergeStats MergeMatchBlocks(
    const std::string& features_path,
    const std::vector<std::string>& block_paths,
    const std::string& output_path);

}  // namespace hisfm
