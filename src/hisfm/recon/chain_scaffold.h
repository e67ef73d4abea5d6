// The sequence pass's chain as a component's scaffold
// (HierarchicalMapperOptions::scaffold_from_sequence_chain): which chain
// model can stand in for the scaffold's incremental reconstruction, and the
// part of it one scaffold segment starts from.
//
// Against Algorithm 1 of the HiSfM paper (its coarse-to-fine step starts
// with incremental SfM on the skeleton): the skeleton's poses come from the
// chain that the sequence pass (recon/sequence_pass.h) has reconstructed
// with this mapper on the consecutive pairs, and every pair left in the
// cleaned database agrees with it; the mapper then refines them from the
// skeleton's edges and the pass's checked pairs.
#pragma once

#include <vector>

#include "hisfm/io/model.h"
#include "hisfm/util/types.h"

namespace hisfm {

/// The first of `chain_models` that registers every image of
/// `skeleton_images`, or null when none does, the skeleton is empty, or the
/// pass kept loop
/// closures (`num_loop_closures` > 0): a chain whose loop closures failed
/// the transfer test drifted past it, and a re-triangulation with its poses
/// fixed cannot bring the loop's ends together.
const Reconstruction* ChainModelForScaffold(
    const std::vector<ImageId>& skeleton_images,
    const std::vector<Reconstruction>& chain_models, size_t num_loop_closures);

/// `chain` without the images outside `images` (RemoveImages: their
/// observations and the points left with fewer than two go too).
Reconstruction ChainSegment(const Reconstruction& chain,
                            std::vector<ImageId> images);

}  // namespace hisfm
