#include "hisfm/recon/chain_scaffold.h"

#include <gtest/gtest.h>

namespace hisfm {
namespace {

// A model registering `ids`, one 3D point seen by all of them.
Reconstruction ModelOf(const std::vector<ImageId>& ids) {
  Reconstruction model;
  Point3D point;
  for (const ImageId id : ids) {
    Image image;
    image.image_id = id;
    image.camera_id = 1;
    Point2D p;
    p.point3D_id = 1;
    image.points2D.push_back(p);
    model.images[id] = image;
    TrackElement element;
    element.image_id = id;
    element.point2D_idx = 0;
    point.track.push_back(element);
  }
  model.points3D[1] = point;
  return model;
}

TEST(ChainModelForScaffold, TheFirstModelHoldingTheWholeSkeleton) {
  const std::vector<Reconstruction> chain = {ModelOf({1, 2, 3}),
                                             ModelOf({4, 5, 6, 7})};
  EXPECT_EQ(ChainModelForScaffold({4, 6}, chain, 0), &chain[1]);
  EXPECT_EQ(ChainModelForScaffold({1, 2, 3}, chain, 0), &chain[0]);
  // A skeleton split between two chain models, or with an image no model
  // registers, is reconstructed.
  EXPECT_EQ(ChainModelForScaffold({3, 4}, chain, 0), nullptr);
  EXPECT_EQ(ChainModelForScaffold({1, 9}, chain, 0), nullptr);
  EXPECT_EQ(ChainModelForScaffold({1}, {}, 0), nullptr);
  EXPECT_EQ(ChainModelForScaffold({}, chain, 0), nullptr);
  // So is any skeleton after the pass kept loop closures.
  EXPECT_EQ(ChainModelForScaffold({4, 6}, chain, 2), nullptr);
}

TEST(ChainSegment, KeepsTheSegmentsImagesAndTheirPoints) {
  const Reconstruction chain = ModelOf({1, 2, 3, 4, 5});
  const Reconstruction segment = ChainSegment(chain, {4, 2, 3});
  EXPECT_EQ(segment.NumRegImages(), 3u);
  EXPECT_EQ(segment.images.count(1), 0u);
  EXPECT_EQ(segment.images.count(4), 1u);
  ASSERT_EQ(segment.points3D.count(1), 1u);
  EXPECT_EQ(segment.points3D.at(1).track.size(), 3u);
  // A point left with one observation goes.
  EXPECT_EQ(ChainSegment(chain, {5}).points3D.count(1), 0u);
}

}  // namespace
}  // namespace hisfm
