#include "hisfm/graph/graph_segments.h"

#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/cuthill_mckee_ordering.hpp>
#include <unordered_map>

#include "hisfm/util/error.h"
#include "hisfm/util/string_util.h"

namespace hisfm {

std::vector<std::pair<size_t, size_t>> OverlappingSpans(size_t n, size_t span,
                                                        size_t overlap) {
  if (n == 0) return {};
  if (span == 0 || n <= span) return {{0, n}};
  ThrowUnless(
      overlap > 0 && overlap < span,
      StrCat("segments: the overlap (", overlap,
             ") must be above 0 and below the segment's size (", span, ")"));
  // m spans of one length, evenly spread from the first place to the last:
  // consecutive ones share at least `overlap` places.
  const size_t m = (n - overlap + span - overlap - 1) / (span - overlap);
  const size_t length = (n - overlap + m - 1) / m + overlap;
  std::vector<std::pair<size_t, size_t>> spans;
  for (size_t j = 0; j < m; ++j) {
    const size_t begin = j * (n - length) / (m - 1);
    spans.push_back({begin, begin + length});
  }
  return spans;
}

std::vector<ImageId> BandedOrder(const std::vector<ImageId>& images,
                                 const std::vector<ImagePair>& edges) {
  using Graph = boost::adjacency_list<
      boost::vecS, boost::vecS, boost::undirectedS,
      boost::property<boost::vertex_color_t, boost::default_color_type>>;
  std::unordered_map<ImageId, size_t> index;
  for (ImageId id : images) index.emplace(id, index.size());
  std::vector<bool> has_edge(images.size(), false);
  Graph graph(images.size());
  for (const ImagePair& e : edges) {
    const auto a = index.find(e.image_id1);
    const auto b = index.find(e.image_id2);
    if (a == index.end() || b == index.end() || a->second == b->second) {
      continue;
    }
    boost::add_edge(a->second, b->second, graph);
    has_edge[a->second] = has_edge[b->second] = true;
  }
  std::vector<size_t> order(images.size());
  boost::cuthill_mckee_ordering(graph, order.begin(),
                                boost::get(boost::vertex_color, graph),
                                boost::make_degree_map(graph));
  std::vector<ImageId> out;
  out.reserve(images.size());
  for (size_t v : order) {
    if (has_edge[v]) out.push_back(images[v]);
  }
  for (size_t v = 0; v < images.size(); ++v) {
    if (!has_edge[v]) out.push_back(images[v]);
  }
  return out;
}

std::vector<std::vector<ImageId>> GraphSegments(
    const std::vector<ImageId>& images, const std::vector<ImagePair>& edges,
    size_t segment_images, size_t overlap) {
  const std::vector<std::pair<size_t, size_t>> spans =
      OverlappingSpans(images.size(), segment_images, overlap);
  if (spans.empty()) return {};
  if (spans.size() == 1) return {images};
  const std::vector<ImageId> order = BandedOrder(images, edges);
  std::vector<std::vector<ImageId>> segments;
  for (const auto& [begin, end] : spans) {
    segments.emplace_back(order.begin() + static_cast<std::ptrdiff_t>(begin),
                          order.begin() + static_cast<std::ptrdiff_t>(end));
  }
  return segments;
}

}  // namespace hisfm
