// Typed identifiers and image-pair helpers shared by every layer.
//
// Image pairs are keyed exactly as COLMAP keys them in its database:
//   pair_id = kMaxNumImages * min(id1, id2) + max(id1, id2),
// with kMaxNumImages = 2^31 - 1 (COLMAP 3.8, src/base/database.cc,
// Database::ImagePairToPairId).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <utility>

namespace hisfm {

/// Identifier of a camera (intrinsics) as stored in COLMAP's `cameras` table.
using CameraId = uint32_t;
/// Identifier of an image as stored in COLMAP's `images` table.
using ImageId = uint32_t;
/// Identifier of a 3D point in a COLMAP model.
using Point3DId = uint64_t;
/// Index of a keypoint inside one image.
using Point2DIdx = uint32_t;
/// COLMAP's 64-bit key of an unordered image pair.
using PairId = uint64_t;
/// Index of a community of the view graph.
using CommunityId = uint32_t;

constexpr CameraId kInvalidCameraId = std::numeric_limits<CameraId>::max();
constexpr ImageId kInvalidImageId = std::numeric_limits<ImageId>::max();
constexpr Point3DId kInvalidPoint3DId = std::numeric_limits<Point3DId>::max();
constexpr CommunityId kInvalidCommunityId =
    std::numeric_limits<CommunityId>::max();
/// COLMAP's bound on image ids, used to encode pair ids.
constexpr uint64_t kMaxNumImages = 2147483647;

/// An unordered pair of images, stored with image_id1 < image_id2.
struct ImagePair {
  ImageId image_id1 = kInvalidImageId;
  ImageId image_id2 = kInvalidImageId;

  ImagePair() = default;
  /// Orders the two ids so that image_id1 < image_id2.
  ImagePair(ImageId a, ImageId b)
      : image_id1(a < b ? a : b), image_id2(a < b ? b : a) {}

  bool operator==(const ImagePair& o) const {
    return image_id1 == o.image_id1 && image_id2 == o.image_id2;
  }
  bool operator!=(const ImagePair& o) const { return !(*this == o); }
  bool operator<(const ImagePair& o) const {
    return image_id1 < o.image_id1 ||
           (image_id1 == o.image_id1 && image_id2 < o.image_id2);
  }
};

/// COLMAP's pair id of two images (order does not matter).
inline PairId ImagePairToPairId(ImageId a, ImageId b) {
  const ImagePair p(a, b);
  return kMaxNumImages * static_cast<uint64_t>(p.image_id1) + p.image_id2;
}

/// Inverse of ImagePairToPairId.
inline ImagePair PairIdToImagePair(PairId pair_id) {
  return ImagePair(static_cast<ImageId>(pair_id / kMaxNumImages),
                   static_cast<ImageId>(pair_id % kMaxNumImages));
}

/// Hash for ImagePair keys in unordered containers.
struct ImagePairHash {
  size_t operator()(const ImagePair& p) const {
    return std::hash<uint64_t>()(ImagePairToPairId(p.image_id1, p.image_id2));
  }
};

}  // namespace hisfm
