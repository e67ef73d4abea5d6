#include "hisfm/recon/input_check.h"

#include <unordered_map>
#include <unordered_set>

#include "hisfm/util/error.h"

namespace hisfm {

void CheckImagesUsable(const Database& database,
                       const std::vector<DatabaseImage>& images,
                       const ViewGraph& graph) {
  std::unordered_set<CameraId> cameras;
  for (const DatabaseCamera& camera : database.ReadCameras()) {
    cameras.insert(camera.camera_id);
  }
  const std::unordered_map<ImageId, size_t> num_keypoints =
      database.ReadNumKeypoints();
  for (const DatabaseImage& im : images) {
    ThrowUnless(cameras.count(im.camera_id) > 0,
                StrCat("database error: image ", im.image_id, " (", im.name,
                       ") refers to camera ", im.camera_id,
                       ", which is not in the cameras table: ",
                       database.path()));
    auto it = num_keypoints.find(im.image_id);
    const bool paired =
        graph.HasImage(im.image_id) &&
        !graph.IncidentEdges(graph.IndexOf(im.image_id)).empty();
    ThrowUnless(!paired || (it != num_keypoints.end() && it->second > 0),
                StrCat("database error: image ", im.image_id, " (", im.name,
                       ") has verified pairs but no keypoints: ",
                       database.path()));
  }
}

}  // namespace hisfm
