// Creation of a new COLMAP 3.8 database (used by the synthetic scenes and by
// tests). The layout is the one documented in hisfm/io/database.h.
#pragma once

#include <string>
#include <vector>

#include "hisfm/io/database.h"

struct sqlite3;

namespace hisfm {

/// Writes a new COLMAP database. The file must not exist yet. Writes go into
/// one transaction that Close() (or the destructor) commits.
class DatabaseWriter {
 public:
  explicit DatabaseWriter(const std::string& path);
  ~DatabaseWriter();
  DatabaseWriter(const DatabaseWriter&) = delete;
  DatabaseWriter& operator=(const DatabaseWriter&) = delete;

  /// Inserts a camera with its given id.
  void WriteCamera(const DatabaseCamera& camera);
  /// Inserts an image with its given id.
  void WriteImage(const DatabaseImage& image);
  /// Keypoints as (x, y) rows; stored with 2 columns, which COLMAP accepts.
  void WriteKeypoints(ImageId image_id, const Keypoints& keypoints);
  void WriteDescriptors(ImageId image_id, const Descriptors& descriptors);
  /// Raw matches, oriented so that idx1 indexes pair.image_id1 (smaller id).
  void WriteMatches(const ImagePair& pair,
                    const std::vector<FeatureMatch>& matches);
  /// A verified pair (matches oriented like WriteMatches; F, E, H row-major).
  void WriteTwoViewGeometry(const TwoViewGeometry& geometry);
  /// Commits and closes; further writes are errors.
  void Close();

 private:
  sqlite3* db_ = nullptr;
  std::string path_;
};

}  // namespace hisfm
