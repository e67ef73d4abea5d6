#include "hisfm/verify/unique_points.h"

#include <cmath>
#include <unordered_map>

#include "hisfm/util/error.h"
#include "hisfm/util/string_util.h"

namespace hisfm {

void UniquePointOptions::Check() const {
  HISFM_CHECK_OPTION(max_relative_distance,
                     std::isfinite(max_relative_distance) &&
                         max_relative_distance > 0.0,
                     "finite and > 0");
  HISFM_CHECK_OPTION(max_far_ties_per_near_tie,
                     std::isfinite(max_far_ties_per_near_tie) &&
                         max_far_ties_per_near_tie >= 0.0,
                     "finite and >= 0");
}

std::unordered_set<Point3DId> FindConfusingPoints(
    const Database& database, const std::vector<ImagePair>& pairs,
    const Reconstruction& model, const UniquePointOptions& options) {
  options.Check();
  std::vector<ImagePair> inside;
  for (const ImagePair& pair : pairs) {
    if (model.images.count(pair.image_id1) &&
        model.images.count(pair.image_id2)) {
      inside.push_back(pair);
    }
  }
  struct Ties {
    size_t near = 0;
    size_t far = 0;
  };
  std::unordered_map<Point3DId, Ties> ties;
  database.ForEachInlierMatches(
      inside, [&](const ImagePair& pair, FeatureMatchSpan matches) {
        const Image& image1 = model.images.at(pair.image_id1);
        const auto& points1 = image1.points2D;
        const auto& points2 = model.images.at(pair.image_id2).points2D;
        for (const FeatureMatch& m : matches) {
          ThrowUnless(m.idx1 < points1.size() && m.idx2 < points2.size(),
                      StrCat("unique points: a match of images ",
                             pair.image_id1, " and ", pair.image_id2,
                             " indexes past the model's keypoints"));
          const auto it1 = model.points3D.find(points1[m.idx1].point3D_id);
          const auto it2 = model.points3D.find(points2[m.idx2].point3D_id);
          if (it1 == model.points3D.end() || it2 == model.points3D.end()) {
            continue;
          }
          if (it1 == it2) {
            ++ties[it1->first].near;
            continue;
          }
          const double depth = (image1.cam_from_world * it1->second.xyz).z();
          const bool near =
              depth > 0.0 && (it1->second.xyz - it2->second.xyz).norm() <=
                                 options.max_relative_distance * depth;
          for (const Point3DId id : {it1->first, it2->first}) {
            ++(near ? ties[id].near : ties[id].far);
          }
        }
      });
  std::unordered_set<Point3DId> confusing;
  for (const auto& [id, t] : ties) {
    if (static_cast<double>(t.far) >
        options.max_far_ties_per_near_tie * static_cast<double>(t.near)) {
      confusing.insert(id);
    }
  }
  return confusing;
}

}  // namespace hisfm
