// One validation pass over a COLMAP database before any work: everything that
// would make HiSfM or colmap crash, hang, exhaust memory or silently ignore
// data is reported as a problem naming its table and row.
//
// Checks (layout in hisfm/io/database.h):
//   cameras:  id in COLMAP's range; a model COLMAP 3.8 knows; width and
//             height positive; params a blob of exactly that model's
//             parameter count, finite, focal lengths positive.
//   images:   id in [0, 2^31 - 1); name text, not empty, without line
//             breaks or other control characters or spaces at either end,
//             unique; camera present.
//   keypoints, descriptors: image present; rows >= 0; cols 2, 4 or 6
//             (keypoints) or 128 (descriptors); blob size rows x cols x
//             element size, compared before anything is allocated; keypoint
//             values finite; descriptors as many as keypoints.
//   two_view_geometries, matches: pair id a COLMAP pair id of two different
//             images that exist; rows >= 0, cols 2, blob rows x 2 uint32;
//             every keypoint index within its image's keypoints;
//             two_view_geometries only: config a TwoViewConfig (0-8), F, E, H
//             (3x3), qvec (4) and tvec (3) empty or of exactly that size and
//             finite.
//
// Policy for problems that only affect some rows (a few non-finite keypoints,
// one pair with a bad index): nothing is skipped or repaired. The commands
// that read a database (mapper, view_graph, filter_pairs, evaluate,
// reconstruct) refuse any database with a problem and name the first one
// (tables in the order above, rows in id order); `hisfm check_database` lists
// them all.
//
// The file itself: where validation reads (every table but the descriptor
// blobs, and the match blobs without check_matches) SQLite's pages must be
// intact, else that table's problem says "the file is corrupt" (also for
// rows out of order, or a row its id does not find). Other damage to the
// SQLite file (descriptor blobs, indexes, b-tree order between rows it
// scans) is not looked for: a full integrity check reads every page, 24 s
// for 1.5 GB. It ends in a one-line error from the command that meets it.
//
// Memory is bounded by the number of images (their names and keypoint
// counts) and one row at a time: keypoint and descriptor blobs are measured
// by SQLite without being read (length()), and a keypoint blob is read only
// once its size matches its row count. The pair tables are scanned in
// chunks of pair ids by two read-only connections.
#pragma once

#include <string>
#include <vector>

namespace hisfm {

/// One problem of a database.
struct DatabaseProblem {
  /// The table: "cameras", "images", "keypoints", "descriptors",
  /// "two_view_geometries" or "matches".
  std::string table;
  /// The row: "camera 3", "image 20", "images 3 and 7", "pair_id 42" (a pair
  /// id that names no two images), or "" for the table as a whole.
  std::string id;
  /// What is wrong, e.g. "rows x cols = 2147483647 x 6 floats does not
  /// match the 245760-byte blob".
  std::string message;
};

/// "table, id: message" (or "table: message" without an id).
std::string FormatDatabaseProblem(const DatabaseProblem& problem);

struct DatabaseValidationOptions {
  /// Stop after this many problems (0: find every problem). The problems
  /// found are always the first ones in table and id order.
  int max_problems = 0;
  /// Also check the raw `matches` table (colmap mapper does not read it,
  /// but filter_pairs copies it and colmap's matchers read it).
  bool check_matches = true;

  /// Throws hisfm::Error naming an invalid option.
  void Check() const;
};

/// Validates the database at `path`. Returns its problems (empty if none).
/// Throws hisfm::Error if the file cannot be opened as a COLMAP database at
/// all (missing, not SQLite, without COLMAP's tables).
std::vector<DatabaseProblem> ValidateDatabase(
    const std::string& path, const DatabaseValidationOptions& options = {});

/// Throws hisfm::Error with one line naming the database and its first
/// problem, and pointing to `hisfm check_database` for the full list, unless
/// the database at `path` has none. Commands call it before any other work.
void RequireValidDatabase(const std::string& path);

}  // namespace hisfm
