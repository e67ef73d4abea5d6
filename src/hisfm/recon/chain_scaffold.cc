#include "hisfm/recon/chain_scaffold.h"

#include <algorithm>
#include <set>

#include "hisfm/recon/model_merge.h"

namespace hisfm {

const Reconstruction* ChainModelForScaffold(
    const std::vector<ImageId>& skeleton_images,
    const std::vector<Reconstruction>& chain_models, size_t num_loop_closures) {
  if (num_loop_closures > 0 || skeleton_images.empty()) return nullptr;
  for (const Reconstruction& model : chain_models) {
    if (std::all_of(skeleton_images.begin(), skeleton_images.end(),
                    [&](ImageId id) { return model.images.count(id) > 0; })) {
      return &model;
    }
  }
  return nullptr;
}

Reconstruction ChainSegment(const Reconstruction& chain,
                            std::vector<ImageId> images) {
  std::sort(images.begin(), images.end());
  Reconstruction model = chain;
  std::set<ImageId> others;
  for (const auto& [id, image] : model.images) {
    if (!std::binary_search(images.begin(), images.end(), id)) {
      others.insert(id);
    }
  }
  RemoveImages(others, &model);
  return model;
}

}  // namespace hisfm
