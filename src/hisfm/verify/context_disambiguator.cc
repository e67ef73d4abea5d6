#include "hisfm/verify/context_disambiguator.h"

#include <algorithm>
#include <cmath>

#include "hisfm/util/error.h"

namespace hisfm {

void DisambiguatorOptions::Check() const {
  HISFM_CHECK_OPTION(grid_cells >= 2 && grid_cells <= 100);
  HISFM_CHECK_OPTION(num_reference_pairs >= 1);
  HISFM_CHECK_OPTION(min_relative_coverage > 0 && min_relative_coverage <= 1);
}

ContextDisambiguator::ContextDisambiguator(const Database& database,
                                           const ViewGraph& graph,
                                           const Communities& communities,
                                           const DisambiguatorOptions& options)
    : database_(database),
      graph_(graph),
      communities_(communities),
      options_(options) {
  options_.Check();
  for (const DatabaseCamera& c : database_.ReadCameras()) {
    cameras_[c.camera_id] = c;
  }
  for (const DatabaseImage& im : database_.ReadImages()) {
    camera_of_image_[im.image_id] = im.camera_id;
  }
}

namespace {

const VerifierContext& CheckedContext(const VerifierContext& context) {
  ThrowUnless(context.database != nullptr && context.graph != nullptr &&
                  context.communities != nullptr,
              "the builtin verifier needs the database, view graph and "
              "communities");
  return context;
}

}  // namespace

ContextDisambiguator::ContextDisambiguator(const VerifierContext& context,
                                           const DisambiguatorOptions& options)
    : ContextDisambiguator(*CheckedContext(context).database, *context.graph,
                           *context.communities, options) {}

const ContextDisambiguator::ImageCache& ContextDisambiguator::Cache(
    ImageId image_id) {
  auto it = cache_.find(image_id);
  if (it != cache_.end()) return it->second;
  ImageCache c;
  const Keypoints keypoints = database_.ReadKeypoints(image_id);
  uint64_t width = 0, height = 0;
  auto cam = camera_of_image_.find(image_id);
  if (cam != camera_of_image_.end()) {
    auto camera = cameras_.find(cam->second);
    if (camera != cameras_.end()) {
      width = camera->second.width;
      height = camera->second.height;
    }
  }
  if (width == 0 || height == 0) {
    // No usable camera size: take the keypoints' extent.
    for (int r = 0; r < keypoints.rows(); ++r) {
      width = std::max<uint64_t>(width, std::ceil(keypoints(r, 0)));
      height = std::max<uint64_t>(height, std::ceil(keypoints(r, 1)));
    }
    width = std::max<uint64_t>(width, 1);
    height = std::max<uint64_t>(height, 1);
  }
  const double cell =
      static_cast<double>(std::max(width, height)) / options_.grid_cells;
  const int nx = static_cast<int>(std::ceil(width / cell));
  const int ny = static_cast<int>(std::ceil(height / cell));
  std::vector<char> textured(static_cast<size_t>(nx) * ny, 0);
  c.cell_of_keypoint.resize(keypoints.rows());
  for (int r = 0; r < keypoints.rows(); ++r) {
    const int cx = std::clamp(static_cast<int>(keypoints(r, 0) / cell), 0,
                              nx - 1);
    const int cy = std::clamp(static_cast<int>(keypoints(r, 1) / cell), 0,
                              ny - 1);
    c.cell_of_keypoint[r] = cy * nx + cx;
    textured[c.cell_of_keypoint[r]] = 1;
  }
  c.num_textured_cells =
      static_cast<int>(std::count(textured.begin(), textured.end(), 1));
  return cache_.emplace(image_id, std::move(c)).first->second;
}

int ContextDisambiguator::CellsOfMatches(ImageId image_id,
                                         const std::vector<FeatureMatch>& m,
                                         bool first) {
  const ImageCache& c = Cache(image_id);
  std::vector<int> cells;
  cells.reserve(m.size());
  for (const FeatureMatch& f : m) {
    const Point2DIdx idx = first ? f.idx1 : f.idx2;
    if (idx < c.cell_of_keypoint.size()) {
      cells.push_back(c.cell_of_keypoint[idx]);
    }
  }
  std::sort(cells.begin(), cells.end());
  return static_cast<int>(std::unique(cells.begin(), cells.end()) -
                          cells.begin());
}

double ContextDisambiguator::ReferenceCells(ImageId image_id) {
  Cache(image_id);
  ImageCache& c = cache_.at(image_id);
  if (c.reference_done) return c.reference_cells;
  c.reference_done = true;
  // The image's strongest intra-community pairs: the trusted neighbours.
  std::vector<std::pair<uint32_t, ImageId>> trusted;
  if (graph_.HasImage(image_id) && communities_.community_of.count(image_id)) {
    const CommunityId own = communities_.Of(image_id);
    for (size_t e : graph_.IncidentEdges(graph_.IndexOf(image_id))) {
      const ImageId other = graph_.OtherEnd(e, image_id);
      auto it = communities_.community_of.find(other);
      if (it == communities_.community_of.end() || it->second != own) continue;
      trusted.push_back({graph_.Edges()[e].weight, other});
    }
  }
  std::sort(trusted.begin(), trusted.end(), [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  if (trusted.size() > static_cast<size_t>(options_.num_reference_pairs)) {
    trusted.resize(options_.num_reference_pairs);
  }
  int best = 0;
  for (const auto& t : trusted) {
    const TwoViewGeometry g = database_.ReadTwoViewGeometry(image_id, t.second);
    best = std::max(best, CellsOfMatches(image_id, g.inlier_matches,
                                         g.pair.image_id1 == image_id));
  }
  // (References into an unordered_map stay valid when it grows.)
  c.has_reference = best > 0;
  c.reference_cells = best;
  return c.reference_cells;
}

double ContextDisambiguator::SceneReferenceFraction() {
  if (scene_reference_fraction_ >= 0) return scene_reference_fraction_;
  std::vector<double> fractions;
  for (ImageId id : graph_.Images()) {
    const double ref = ReferenceCells(id);
    const ImageCache& c = cache_.at(id);
    if (c.has_reference && c.num_textured_cells > 0) {
      fractions.push_back(ref / c.num_textured_cells);
    }
  }
  if (fractions.empty()) {
    scene_reference_fraction_ = 1.0;
  } else {
    std::nth_element(fractions.begin(),
                     fractions.begin() + fractions.size() / 2,
                     fractions.end());
    scene_reference_fraction_ = fractions[fractions.size() / 2];
  }
  return scene_reference_fraction_;
}

BridgeEvidence ContextDisambiguator::Evaluate(const ImagePair& pair) {
  BridgeEvidence ev;
  ev.pair = pair;
  const TwoViewGeometry g =
      database_.ReadTwoViewGeometry(pair.image_id1, pair.image_id2);
  ev.num_inliers = static_cast<uint32_t>(g.inlier_matches.size());
  ev.cells1 = CellsOfMatches(g.pair.image_id1, g.inlier_matches, true);
  ev.cells2 = CellsOfMatches(g.pair.image_id2, g.inlier_matches, false);
  auto reference = [&](ImageId id) {
    const double ref = ReferenceCells(id);
    const ImageCache& c = cache_.at(id);
    if (c.has_reference) return ref;
    // An image without a trusted neighbour: the scene's typical fraction of
    // its textured cells.
    return std::max(1.0, SceneReferenceFraction() * c.num_textured_cells);
  };
  ev.reference1 = reference(g.pair.image_id1);
  ev.reference2 = reference(g.pair.image_id2);
  ev.relative1 = std::min(1.0, ev.cells1 / ev.reference1);
  ev.relative2 = std::min(1.0, ev.cells2 / ev.reference2);
  ev.relative = std::min(ev.relative1, ev.relative2);
  ev.score =
      std::min(1.0, ev.relative / (2.0 * options_.min_relative_coverage));
  return ev;
}

std::vector<double> ContextDisambiguator::Score(
    const std::vector<ImagePair>& pairs) {
  std::vector<double> scores;
  scores.reserve(pairs.size());
  for (const ImagePair& p : pairs) scores.push_back(Evaluate(p).score);
  return scores;
}

}  // namespace hisfm
