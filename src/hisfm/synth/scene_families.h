// Parametric scene families for tuning and held-out evaluation: each family
// is a kind of scene with repeated structure whose geometry is set by
// SynthFamilyOptions (drawn from documented ranges with --randomize_family),
// so that (family, number of images, seed) defines an instance.
//
// Families (z is up, metres; P = period, D = facade_distance, s =
// camera_spacing):
//  - facade_street: one facade in the plane y = D facing the street, 12 m
//    high, its motif (one period P wide: wall, pillar, windows, balconies,
//    with relief_depth) repeated along x; cameras at y ~ 0, 1.6 m high,
//    every s metres along x, looking at the facade (pitched up 8 degrees).
//  - block_loop: a rectangular block centred at the origin whose four sides
//    (multiples of P, at least one P) carry the motif and whose four corners
//    carry one corner-pillar motif; cameras walk a closed loop at distance D
//    around it (straight along the sides, quarter circles around the
//    corners), looking at the block.
//  - crossing_streets: street A along x and street B along y crossing at the
//    origin; four corner buildings whose faces lie at distance D from the
//    streets' centre lines carry the motif, their corners the corner motif;
//    the first half of the images walks street A (+x) looking left-ahead,
//    the second half street B (+y) looking right-ahead, at view_angle from
//    the street: A's north and B's east facades are photographed, and both
//    walks look at the same building corner (north-east) while they cross.
//  - symmetric_object: the cylinder of symmetric2 (radius 1, height 1.6)
//    with an n-fold print (symmetry_order), a ring of cameras of radius
//    ring_radius, a unique surrounding wall and ground of clutter_density
//    points per object point.
// The streets carry unique clutter (poles, trees, parked cars, kiosks; one
// object per 5 m of facade, within 0.6 D of it), which hides facade points,
// and optionally a unique ground. With unique_pattern every copy of the motif is
// different (the family's control).
//
// Facade point density: the facades carry 800 * object_density points per
// image area seen head-on from D (about 18 per m^2 at D = 6 m with the
// default camera), i.e. the density falls as 1 / D^2: a farther facade
// shows coarser texture to a detector of fixed image resolution. Likewise
// points seen farther than D or obliquely are detected less often
// (SceneLayout::detection_reference_distance = D), so that an image holds
// about 500 keypoints whatever it looks at.
#pragma once

#include "hisfm/synth/scene_layout.h"
#include "hisfm/synth/synth_options.h"

namespace hisfm {

/// The family parameters of an instance: options.family, or with
/// options.family.randomize the parameters marked "random" in
/// SynthFamilyOptions drawn from their ranges with a generator seeded by
/// options.seed and the family (not by num_images). The result has
/// randomize = false. Throws hisfm::Error on invalid options.
SynthFamilyOptions ResolveFamilyOptions(const SynthOptions& options);

/// Builds the points, occluders, cameras and symmetry of a family scene
/// (IsSynthFamily(type)) into an empty layout; layout->family_options gets
/// the resolved parameters, with block_loop's camera_spacing replaced by the
/// spacing actually used. Throws hisfm::Error if the scene needs more than
/// kMaxFamilyReplicas copies of its motifs.
void BuildFamilyLayout(const SynthOptions& options, SynthSceneType type,
                       SceneLayout* layout);

/// Most copies of a motif (facade periods and corners) a family scene may
/// hold: the relation table between copies grows with their square.
constexpr size_t kMaxFamilyReplicas = 4096;

}  // namespace hisfm
