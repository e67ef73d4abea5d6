#include "hisfm/report/report_writer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "hisfm/report/report_json_check.h"
#include "hisfm/report/top_view.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"

namespace fs = std::filesystem;

namespace hisfm {

void ReportOptions::Check() const {
  HISFM_CHECK_OPTION(max_points, max_points >= 1, ">= 1");
  HISFM_CHECK_OPTION(max_table_rows, max_table_rows >= 1, ">= 1");
  HISFM_CHECK_OPTION(drawing_width, drawing_width >= 200, ">= 200");
}

namespace {

using Json = nlohmann::json;

// ---------------------------------------------------------------------------
// Formatting.

std::string Esc(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Fixed(double v, int precision) {
  if (!std::isfinite(v)) return "&ndash;";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", precision, v);
  return buf;
}

// Compact coordinate for SVG (one decimal).
std::string C(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f", v);
  return buf;
}

// A JSON number (or "-" if missing/null).
std::string JNum(const Json& j, const char* key, int precision) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) {
    return "&ndash;";
  }
  return Fixed(j[key].get<double>(), precision);
}

std::string JStr(const Json& j, const char* key) {
  if (!j.is_object() || !j.contains(key)) return "";
  if (j[key].is_string()) return j[key].get<std::string>();
  return j[key].dump();
}

double JDouble(const Json& j, const char* key, double fallback = 0.0) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) {
    return fallback;
  }
  return j[key].get<double>();
}

std::string Seconds(double s) {
  if (s < 10) return Fixed(s, 2) + " s";
  if (s < 120) return Fixed(s, 1) + " s";
  return StrCat(static_cast<long>(s / 60), " min ",
                static_cast<long>(std::lround(std::fmod(s, 60.0))), " s");
}

// Colour of a community: hues spaced by the golden angle.
std::string CommunityColor(int community) {
  if (community < 0) return "#888888";
  const double hue = std::fmod(community * 137.508, 360.0);
  const double lightness = community % 2 == 0 ? 45.0 : 58.0;
  char buf[48];
  std::snprintf(buf, sizeof(buf), "hsl(%.0f,70%%,%.0f%%)", hue, lightness);
  return buf;
}

std::string Hex(int r, int g, int b) {
  char buf[8];
  std::snprintf(buf, sizeof(buf), "#%02x%02x%02x", r, g, b);
  return buf;
}

std::string NowText() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d %H:%M:%S", &tm);
  return buf;
}

// ---------------------------------------------------------------------------
// Viewport: world 2D coordinates (y up) to SVG coordinates (y down),
// uniform scale, centred.

struct Viewport {
  double min_x = 0, min_y = 0, scale = 1, off_x = 0, off_y = 0;
  double width = 0, height = 0;

  Eigen::Vector2d Map(const Eigen::Vector2d& p) const {
    return {off_x + (p.x() - min_x) * scale,
            height - (off_y + (p.y() - min_y) * scale)};
  }
};

Viewport FitViewport(double min_x, double max_x, double min_y, double max_y,
                     double width, double min_height, double max_height,
                     double margin) {
  Viewport v;
  double span_x = max_x - min_x, span_y = max_y - min_y;
  if (!(span_x > 0) && !(span_y > 0)) span_x = span_y = 1.0;
  if (!(span_x > 0)) span_x = span_y * 1e-3;
  if (!(span_y > 0)) span_y = span_x * 1e-3;
  v.min_x = min_x;
  v.min_y = min_y;
  v.width = width;
  v.scale = (width - 2 * margin) / span_x;
  v.height = span_y * v.scale + 2 * margin;
  if (v.height > max_height) {
    v.height = max_height;
    v.scale = (max_height - 2 * margin) / span_y;
  }
  v.height = std::max(v.height, min_height);
  v.off_x = (width - span_x * v.scale) / 2;
  v.off_y = (v.height - span_y * v.scale) / 2;
  return v;
}

struct Bounds {
  double min_x = 1e300, max_x = -1e300, min_y = 1e300, max_y = -1e300;
  void Add(const Eigen::Vector2d& p) {
    min_x = std::min(min_x, p.x());
    max_x = std::max(max_x, p.x());
    min_y = std::min(min_y, p.y());
    max_y = std::max(max_y, p.y());
  }
  bool Empty() const { return min_x > max_x; }
  bool Contains(const Eigen::Vector2d& p) const {
    return p.x() >= min_x && p.x() <= max_x && p.y() >= min_y &&
           p.y() <= max_y;
  }
  void Expand(double fraction) {
    const double dx = (max_x - min_x) * fraction + 1e-12;
    const double dy = (max_y - min_y) * fraction + 1e-12;
    min_x -= dx;
    max_x += dx;
    min_y -= dy;
    max_y += dy;
  }
};

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1,
                            static_cast<size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// ---------------------------------------------------------------------------
// Hierarchy JSON access.

struct GraphImage {
  uint32_t id = 0;
  std::string name;
  int community = -1;
  bool skeletal = false;
};

struct GraphEdge {
  uint32_t a = 0, b = 0;
  double inliers = 0;
  double score = 1.0;
  int community1 = -1, community2 = -1;
  int tree = -1;
  std::string role;
};

std::vector<GraphImage> HierarchyImages(const Json& h) {
  std::vector<GraphImage> out;
  if (!h.is_object() || !h.contains("images")) return out;
  for (const Json& im : h["images"]) {
    GraphImage g;
    g.id = im.value("image_id", 0u);
    g.name = im.value("name", "");
    g.community = im.value("community", -1);
    g.skeletal = im.value("skeletal", false);
    out.push_back(g);
  }
  return out;
}

std::vector<GraphEdge> HierarchyEdges(const Json& h, const char* key) {
  std::vector<GraphEdge> out;
  if (!h.is_object() || !h.contains(key) || !h[key].is_array()) return out;
  for (const Json& e : h[key]) {
    GraphEdge g;
    g.a = e.value("image_id1", 0u);
    g.b = e.value("image_id2", 0u);
    g.inliers = e.value("inliers", 0.0);
    g.score = e.contains("score") && e["score"].is_number()
                  ? e["score"].get<double>()
                  : NAN;
    g.community1 = e.value("community1", -1);
    g.community2 = e.value("community2", -1);
    g.tree = e.value("tree", -1);
    g.role = e.value("role", "");
    out.push_back(g);
  }
  return out;
}

// Community of each image name (for colouring cameras).
std::map<std::string, int> CommunityByName(const Json& h) {
  std::map<std::string, int> out;
  for (const GraphImage& im : HierarchyImages(h)) out[im.name] = im.community;
  return out;
}

// ---------------------------------------------------------------------------
// Sections.

std::string Card(const std::string& label, const std::string& value,
                 const std::string& detail = "") {
  std::string out = "<div class=\"card\"><div class=\"value\">" + value +
                    "</div><div class=\"label\">" + Esc(label) + "</div>";
  if (!detail.empty()) out += "<div class=\"detail\">" + detail + "</div>";
  return out + "</div>\n";
}

// The summary of the model itself, from the summary json or the model.
std::string SummarySection(const ReportInput& in) {
  const Json& s = in.summary;
  std::string cards;
  const bool has_summary = s.is_object() && !s.empty();
  if (has_summary && s.contains("registered_images")) {
    cards += Card("images registered",
                  StrCat(JStr(s, "registered_images"), " / ", JStr(s, "images")),
                  StrCat(s.contains("models") ? s["models"].size() : 0,
                         " model(s)"));
  } else if (in.model) {
    cards += Card("images registered", StrCat(in.model->NumRegImages()));
  }
  if (in.model) {
    const Reconstruction& m = *in.model;
    cards += Card("3D points", StrCat(m.NumPoints3D()),
                  StrCat(m.NumObservations(), " observations"));
    cards += Card("mean track length", Fixed(m.MeanTrackLength(), 2));
    cards += Card("mean reprojection error",
                  Fixed(m.MeanReprojectionError(), 3) + " px");
  } else if (has_summary) {
    cards += Card("3D points", JStr(s, "points3D"));
    cards += Card("mean track length", JNum(s, "mean_track_length", 2));
    cards += Card("mean reprojection error",
                  JNum(s, "mean_reprojection_error", 3) + " px");
  }
  if (has_summary && s.contains("communities")) {
    cards += Card("communities", JStr(s, "communities"),
                  StrCat(JStr(s, "verified_pairs"), " verified pairs"));
    cards += Card("skeleton",
                  StrCat(JStr(s, "skeleton_images"), " images"),
                  StrCat("K = ", JStr(s, "num_trees"), ", ",
                         JStr(s, "skeleton_bridges"), " bridges taken, ",
                         JStr(s, "rejected_bridges"), " rejected"));
    cards += Card("verifier", Esc(JStr(s, "verifier")),
                  StrCat(JStr(s, "verifier_calls"), " pairs scored (",
                         Fixed(100 * JDouble(s, "verified_fraction"), 1),
                         "% of all)"));
  }
  if (has_summary && s.contains("timings") && s["timings"].contains("total")) {
    cards += Card("mapper time", Seconds(JDouble(s["timings"], "total")));
  }
  if (cards.empty()) return "";
  return "<h2>Summary</h2>\n<div class=\"cards\">\n" + cards + "</div>\n";
}

std::string VerdictBadge(const Json& evaluation) {
  if (!evaluation.is_object() || !evaluation.contains("correct")) {
    return "<span class=\"badge none\">not evaluated</span>";
  }
  if (evaluation["correct"].get<bool>()) {
    return "<span class=\"badge ok\">correct</span>";
  }
  const std::string reason = JStr(evaluation, "verdict_reason");
  return "<span class=\"badge bad\">incorrect</span>" +
         (reason.empty() ? "" : " <span class=\"reason\">" + Esc(reason) +
                                    "</span>");
}

// The single-model part of an evaluation (the largest model of a
// multi-model evaluation).
const Json& SingleEvaluation(const Json& evaluation) {
  if (evaluation.is_object() && evaluation.contains("largest")) {
    return evaluation["largest"];
  }
  return evaluation;
}

std::string PairsWithin(const Json& single, double threshold) {
  if (!single.is_object() || !single.contains("pairs_within")) {
    return "&ndash;";
  }
  for (const Json& w : single["pairs_within"]) {
    if (std::abs(w.value("threshold_deg", -1.0) - threshold) < 1e-9) {
      return Fixed(100 * w.value("fraction", 0.0), 1) + "%";
    }
  }
  return "&ndash;";
}

std::string EvaluationSection(const ReportInput& in) {
  if (!in.evaluation.is_object() || in.evaluation.empty()) return "";
  const Json& e = in.evaluation;
  const Json& single = SingleEvaluation(e);
  std::string out = "<h2>Evaluation against the reference</h2>\n<p>" +
                    VerdictBadge(e) + "</p>\n<table class=\"kv\">\n";
  auto row = [&](const std::string& k, const std::string& v) {
    out += "<tr><th>" + Esc(k) + "</th><td>" + v + "</td></tr>\n";
  };
  row("reference images registered",
      StrCat(JStr(single, "num_registered"), " / ",
             JStr(single, "num_reference_images")));
  if (e.contains("num_models")) {
    row("models", StrCat(JStr(e, "num_models"),
                         e.value("oversplit", false) ? " (split)" : ""));
  }
  row("image pairs compared", JStr(single, "num_pairs"));
  row("median rotation error", JNum(single, "median_rotation_error_deg", 2) +
                                   "&deg;");
  row("median translation direction error",
      JNum(single, "median_translation_error_deg", 2) + "&deg;");
  if (single.contains("pairs_within")) {
    std::string within;
    for (const Json& w : single["pairs_within"]) {
      within += StrCat(within.empty() ? "" : ", ", "&le; ",
                       Fixed(w.value("threshold_deg", 0.0), 0), "&deg;: ",
                       Fixed(100 * w.value("fraction", 0.0), 1), "%");
    }
    row("pairs within", within);
  }
  if (single.contains("camera_centers") &&
      single["camera_centers"].value("aligned", false)) {
    row("camera centre error (after alignment)",
        StrCat("median ",
               Fixed(100 * JDouble(single["camera_centers"], "median_error"),
                     2),
               "% of the scene extent"));
  }
  out += "</table>\n";
  return out;
}

std::string ComparisonSection(const ReportInput& in) {
  if (in.comparison.empty()) return "";
  std::string out =
      "<h2>Comparison</h2>\n<table class=\"grid\">\n<tr><th>method</th>"
      "<th>verdict</th><th>registered</th><th>models</th><th>median "
      "rotation error</th><th>pairs within 5&deg;</th><th>time</th></tr>\n";
  double max_seconds = 0;
  for (const ReportMethodResult& m : in.comparison) {
    max_seconds = std::max(max_seconds, m.seconds);
  }
  for (const ReportMethodResult& m : in.comparison) {
    const Json& single = SingleEvaluation(m.evaluation);
    const double bar =
        max_seconds > 0 ? 100.0 * m.seconds / max_seconds : 0.0;
    out += "<tr><td><b>" + Esc(m.method) + "</b></td><td>" +
           VerdictBadge(m.evaluation) + "</td><td>" +
           StrCat(m.registered_images, " / ", m.num_images) + "</td><td>" +
           StrCat(m.num_models) + "</td><td>" +
           JNum(single, "median_rotation_error_deg", 2) + "&deg;</td><td>" +
           PairsWithin(single, 5.0) + "</td><td class=\"time\"><div class=\"tbar\" "
           "style=\"width:" + Fixed(0.8 * bar, 0) + "px\"></div> " +
           Seconds(m.seconds) + "</td></tr>\n";
  }
  return out + "</table>\n";
}

// Positions of the graph's images: top view of the model, or circles.
struct GraphLayout {
  std::map<uint32_t, Eigen::Vector2d> position;
  std::set<uint32_t> unregistered;
  bool from_model = false;
};

GraphLayout LayoutGraph(const std::vector<GraphImage>& images,
                        const std::optional<Reconstruction>& model) {
  GraphLayout layout;
  if (model && !model->images.empty()) {
    const TopViewFrame frame = ComputeTopViewFrame(*model);
    Bounds b;
    for (const GraphImage& im : images) {
      const Image* m = model->FindImageWithName(im.name);
      if (m == nullptr) {
        layout.unregistered.insert(im.id);
        continue;
      }
      layout.position[im.id] = frame.Project(m->ProjectionCenter());
      b.Add(layout.position[im.id]);
    }
    if (!b.Empty()) {
      layout.from_model = true;
      // Unregistered images: a row below the drawing.
      const double span = std::max(b.max_x - b.min_x, b.max_y - b.min_y);
      const double y = b.min_y - 0.12 * std::max(span, 1e-9);
      size_t k = 0;
      const size_t n = layout.unregistered.size();
      for (uint32_t id : layout.unregistered) {
        const double t = n == 1 ? 0.5 : static_cast<double>(k) / (n - 1);
        layout.position[id] = {b.min_x + t * (b.max_x - b.min_x), y};
        ++k;
      }
      return layout;
    }
    layout.unregistered.clear();
  }
  std::map<uint32_t, int> community_of;
  for (const GraphImage& im : images) community_of[im.id] = im.community;
  layout.position = CommunityCircleLayout(community_of);
  if (model) {
    for (const GraphImage& im : images) {
      if (model->FindImageWithName(im.name) == nullptr) {
        layout.unregistered.insert(im.id);
      }
    }
  }
  return layout;
}

std::string Line(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                 const std::string& title) {
  std::string out = "<line x1=\"" + C(a.x()) + "\" y1=\"" + C(a.y()) +
                    "\" x2=\"" + C(b.x()) + "\" y2=\"" + C(b.y()) + "\"";
  if (title.empty()) return out + "/>";
  return out + "><title>" + Esc(title) + "</title></line>";
}

// Where the view graph's images are drawn.
struct GraphDrawing {
  std::map<uint32_t, const GraphImage*> by_id;
  GraphLayout layout;
  Viewport vp;
  // Radius of a skeletal image's dot.
  double r = 0;

  std::optional<Eigen::Vector2d> Pos(uint32_t id) const {
    auto it = layout.position.find(id);
    if (it == layout.position.end()) return std::nullopt;
    return vp.Map(it->second);
  }
  std::string Name(uint32_t id) const {
    auto it = by_id.find(id);
    return it == by_id.end() ? StrCat("#", id) : it->second->name;
  }
};

// Lays the images out (at their camera centres, or community circles) and
// fits them into the drawing.
GraphDrawing PlaceGraph(const std::vector<GraphImage>& images,
                        const ReportInput& in, const ReportOptions& options) {
  GraphDrawing d;
  for (const GraphImage& im : images) d.by_id[im.id] = &im;
  d.layout = LayoutGraph(images, in.model);
  Bounds b;
  for (const auto& [id, p] : d.layout.position) b.Add(p);
  const double width = options.drawing_width;
  d.vp = FitViewport(b.min_x, b.max_x, b.min_y, b.max_y, width, 320, 760, 40);
  d.r = std::clamp(60.0 / std::sqrt(static_cast<double>(
                                std::max<size_t>(images.size(), 1))),
                   2.5, 7.0);
  return d;
}

// The hierarchy's edges by kind, as drawn.
struct HierarchyEdgeSets {
  std::vector<GraphEdge> leaves, intra, bridges, rejected;
};

// The edge groups: leaf edges, intra-community skeleton edges, rejected
// bridges, skeleton bridges (drawn in this order).
void DrawGraphEdges(const GraphDrawing& d, const HierarchyEdgeSets& edges,
                    std::ostringstream& svg) {
  svg << "<g class=\"e-leaf\">\n";
  for (const GraphEdge& e : edges.leaves) {
    const auto a = d.Pos(e.a), c = d.Pos(e.b);
    if (!a || !c) continue;
    svg << Line(*a, *c,
                StrCat("leaf edge ", d.Name(e.a), " - ", d.Name(e.b), ", ",
                       e.inliers, " inliers"))
        << '\n';
  }
  svg << "</g>\n<g class=\"e-intra\">\n";
  for (const GraphEdge& e : edges.intra) {
    const auto a = d.Pos(e.a), c = d.Pos(e.b);
    if (!a || !c) continue;
    const int community =
        d.by_id.count(e.a) ? d.by_id.at(e.a)->community : -1;
    svg << "<g stroke=\"" << CommunityColor(community) << "\">"
        << Line(*a, *c,
                StrCat("skeleton edge ", d.Name(e.a), " - ", d.Name(e.b),
                       ", ", e.inliers, " inliers"))
        << "</g>\n";
  }
  svg << "</g>\n<g class=\"e-rejected\">\n";
  for (const GraphEdge& e : edges.rejected) {
    const auto a = d.Pos(e.a), c = d.Pos(e.b);
    if (!a || !c) continue;
    svg << Line(*a, *c,
                StrCat("rejected bridge ", d.Name(e.a), " - ", d.Name(e.b),
                       ", communities ", e.community1, "-", e.community2,
                       ", ", e.inliers, " inliers, score ", Fixed(e.score, 3)))
        << '\n';
  }
  svg << "</g>\n<g class=\"e-bridge\">\n";
  for (const GraphEdge& e : edges.bridges) {
    const auto a = d.Pos(e.a), c = d.Pos(e.b);
    if (!a || !c) continue;
    svg << Line(*a, *c,
                StrCat("skeleton bridge ", d.Name(e.a), " - ", d.Name(e.b),
                       ", communities ", e.community1, "-", e.community2,
                       ", ", e.inliers, " inliers, score ", Fixed(e.score, 3),
                       e.tree >= 0 ? StrCat(", tree ", e.tree) : "",
                       e.role.empty() ? "" : ", " + e.role))
        << '\n';
  }
  svg << "</g>\n";
}

// One dot per image: large for skeletal images, small for leaves, outlined
// when not registered.
void DrawGraphNodes(const GraphDrawing& d,
                    const std::vector<GraphImage>& images,
                    std::ostringstream& svg) {
  svg << "<g class=\"nodes\">\n";
  for (const GraphImage& im : images) {
    const auto p = d.Pos(im.id);
    if (!p) continue;
    const bool unregistered = d.layout.unregistered.count(im.id) > 0;
    svg << "<circle cx=\"" << C(p->x()) << "\" cy=\"" << C(p->y())
        << "\" r=\"" << C(im.skeletal ? d.r : 0.72 * d.r) << "\" fill=\""
        << (unregistered ? "#ffffff" : CommunityColor(im.community))
        << "\" class=\"" << (im.skeletal ? "skel" : "leaf")
        << (unregistered ? " unreg" : "") << "\"";
    if (unregistered) {
      svg << " stroke=\"" << CommunityColor(im.community) << "\"";
    }
    svg << "><title>"
        << Esc(StrCat(im.name, " (image ", im.id, "), community ",
                      im.community, ", ", im.skeletal ? "skeletal" : "leaf",
                      unregistered ? ", not registered" : ""))
        << "</title></circle>\n";
  }
  svg << "</g>\n";
}

// The scores of the `max_labels` strongest rejected bridges. Each label goes
// to the first point along its bridge (middle first) that keeps clear of the
// labels placed before it.
void DrawBridgeLabels(const GraphDrawing& d,
                      const std::vector<GraphEdge>& rejected,
                      size_t max_labels, std::ostringstream& svg) {
  svg << "<g class=\"e-label\">\n";
  std::vector<const GraphEdge*> labelled;
  for (const GraphEdge& e : rejected) labelled.push_back(&e);
  std::sort(labelled.begin(), labelled.end(),
            [](const GraphEdge* x, const GraphEdge* y) {
              return x->inliers > y->inliers;
            });
  if (labelled.size() > max_labels) labelled.resize(max_labels);
  std::vector<Eigen::Vector2d> placed;
  for (const GraphEdge* e : labelled) {
    const auto a = d.Pos(e->a), c = d.Pos(e->b);
    if (!a || !c) continue;
    Eigen::Vector2d m = 0.5 * (*a + *c);
    for (double t : {0.5, 0.38, 0.62, 0.28, 0.72, 0.2, 0.8}) {
      const Eigen::Vector2d q = *a + t * (*c - *a);
      const bool clear = std::none_of(
          placed.begin(), placed.end(), [&](const Eigen::Vector2d& p) {
            return std::abs(p.x() - q.x()) < 30 && std::abs(p.y() - q.y()) < 13;
          });
      if (clear) {
        m = q;
        break;
      }
    }
    placed.push_back(m);
    svg << "<text x=\"" << C(m.x()) << "\" y=\"" << C(m.y() - 3) << "\">"
        << Fixed(e->score, 2) << "</text>\n";
  }
  svg << "</g>\n";
}

// The view graph drawing (SVG).
std::string ViewGraphSvg(const GraphDrawing& d,
                         const std::vector<GraphImage>& images,
                         const HierarchyEdgeSets& edges,
                         const ReportOptions& options) {
  std::ostringstream svg;
  svg << "<svg class=\"drawing\" viewBox=\"0 0 " << C(d.vp.width) << ' '
      << C(d.vp.height) << "\" role=\"img\" aria-label=\"view graph\">\n";
  svg << "<rect class=\"bg\" width=\"" << C(d.vp.width) << "\" height=\""
      << C(d.vp.height) << "\"/>\n";
  if (d.layout.from_model && !d.layout.unregistered.empty()) {
    const auto p = d.Pos(*d.layout.unregistered.begin());
    svg << "<text class=\"note\" x=\"10\" y=\"" << C(p->y() - 2 * d.r - 4)
        << "\">not registered:</text>\n";
  }
  DrawGraphEdges(d, edges, svg);
  DrawGraphNodes(d, images, svg);
  DrawBridgeLabels(d, edges.rejected, options.max_bridge_labels, svg);
  svg << "</svg>\n";
  return svg.str();
}

std::string ViewGraphSection(const ReportInput& in,
                             const ReportOptions& options) {
  const std::vector<GraphImage> images = HierarchyImages(in.hierarchy);
  if (images.empty()) return "";
  const GraphDrawing d = PlaceGraph(images, in, options);
  HierarchyEdgeSets edges;
  edges.leaves = HierarchyEdges(in.hierarchy, "leaf_edges");
  edges.intra = HierarchyEdges(in.hierarchy, "skeleton_intra_edges");
  edges.bridges = HierarchyEdges(in.hierarchy, "skeleton_bridges");
  edges.rejected = HierarchyEdges(in.hierarchy, "rejected_bridges");

  std::ostringstream out;
  out << "<h2>View graph and hierarchy</h2>\n<p class=\"caption\">"
      << images.size() << " images in "
      << in.hierarchy.value("num_communities", 0) << " communities (one "
      << "colour each); large outlined dots are skeletal images, small dots "
      << "leaves. "
      << (d.layout.from_model
              ? "Images are placed at their reconstructed camera centres "
                "(top view of the model)."
              : "Each community is drawn on its own circle (no model).")
      << " Hover over a dot or a line for details.</p>\n";
  out << "<div class=\"toggles\">\n"
      << "<input type=\"checkbox\" id=\"t-leaf\" checked><label "
         "for=\"t-leaf\"><span class=\"sw sw-leaf\"></span>leaf edges ("
      << edges.leaves.size() << ")</label>\n"
      << "<input type=\"checkbox\" id=\"t-intra\" checked><label "
         "for=\"t-intra\"><span class=\"sw sw-intra\"></span>skeleton edges "
         "in a community ("
      << edges.intra.size() << ")</label>\n"
      << "<input type=\"checkbox\" id=\"t-bridge\" checked><label "
         "for=\"t-bridge\"><span class=\"sw sw-bridge\"></span>skeleton "
         "bridges ("
      << edges.bridges.size() << ")</label>\n"
      << "<input type=\"checkbox\" id=\"t-rejected\" checked><label "
         "for=\"t-rejected\"><span class=\"sw sw-rejected\"></span>rejected "
         "bridges ("
      << edges.rejected.size() << ")</label>\n"
      << "<input type=\"checkbox\" id=\"t-label\" checked><label "
         "for=\"t-label\">scores of rejected bridges</label>\n"
      << "<div class=\"figure\">\n"
      << ViewGraphSvg(d, images, edges, options) << "</div>\n</div>\n";
  return out.str();
}

std::string BridgeTable(const ReportInput& in, const ReportOptions& options) {
  const std::vector<GraphEdge> bridges =
      HierarchyEdges(in.hierarchy, "skeleton_bridges");
  const std::vector<GraphEdge> rejected =
      HierarchyEdges(in.hierarchy, "rejected_bridges");
  if (bridges.empty() && rejected.empty()) return "";
  std::map<uint32_t, std::string> names;
  for (const GraphImage& im : HierarchyImages(in.hierarchy)) {
    names[im.id] = im.name;
  }
  std::string out =
      "<details><summary>Bridges between communities (" +
      StrCat(bridges.size(), " taken, ", rejected.size(), " rejected") +
      ")</summary>\n<table class=\"grid\">\n<tr><th>status</th><th>image "
      "1</th><th>image 2</th><th>communities</th><th>inliers</th>"
      "<th>score</th><th>tree</th></tr>\n";
  size_t rows = 0;
  auto add = [&](const GraphEdge& e, bool taken) {
    if (rows++ >= options.max_table_rows) return;
    out += StrCat("<tr class=\"", taken ? "taken" : "rejected", "\"><td>",
                  taken ? "taken" : "rejected", "</td><td>", Esc(names[e.a]),
                  "</td><td>", Esc(names[e.b]), "</td><td>", e.community1,
                  " &ndash; ", e.community2, "</td><td>", e.inliers,
                  "</td><td>", Fixed(e.score, 3), "</td><td>",
                  e.tree >= 0 ? StrCat(e.tree) : Esc(e.role), "</td></tr>\n");
  };
  for (const GraphEdge& e : bridges) add(e, true);
  for (const GraphEdge& e : rejected) add(e, false);
  out += "</table>\n";
  if (rows > options.max_table_rows) {
    out += StrCat("<p class=\"caption\">", rows - options.max_table_rows,
                  " more not shown.</p>\n");
  }
  return out + "</details>\n";
}

// Top view of `model` with the input's reference overlaid and cameras
// coloured by the input's communities, under the heading `title`.
// The points inside `clip`, grouped by colour (3 bits per channel), one
// path per colour; returns how many were drawn.
size_t DrawTopViewPoints(
    const std::vector<std::pair<Eigen::Vector2d, const Point3D*>>& points,
    const Bounds& clip, const Viewport& vp, std::ostringstream& svg) {
  std::map<int, std::string> paths;
  size_t drawn = 0;
  for (const auto& [q, p] : points) {
    if (!clip.Contains(q)) continue;
    const Eigen::Vector2d s = vp.Map(q);
    const int key = ((p->color(0) >> 5) << 6) | ((p->color(1) >> 5) << 3) |
                    (p->color(2) >> 5);
    paths[key] += "M" + C(s.x()) + " " + C(s.y()) + "h0";
    ++drawn;
  }
  svg << "<g class=\"points\">\n";
  for (const auto& [key, d] : paths) {
    const int r = ((key >> 6) & 7) * 255 / 7, g = ((key >> 3) & 7) * 255 / 7,
              bl = (key & 7) * 255 / 7;
    svg << "<path stroke=\"" << Hex(r, g, bl) << "\" d=\"" << d << "\"/>\n";
  }
  svg << "</g>\n";
  return drawn;
}

// The reference cameras (`refs`, in the model's top view) as squares, each
// joined by a thin line to the model's camera of the same name.
void DrawReferenceCameras(
    const Reconstruction& model, const TopViewFrame& frame,
    const std::vector<std::pair<std::string, Eigen::Vector2d>>& refs,
    const Viewport& vp, double cam_r, std::ostringstream& svg) {
  if (refs.empty()) return;
  svg << "<g class=\"ref-links\">\n";
  for (const auto& [name, q] : refs) {
    const Image* m = model.FindImageWithName(name);
    if (m == nullptr) continue;
    svg << Line(vp.Map(frame.Project(m->ProjectionCenter())), vp.Map(q), "")
        << '\n';
  }
  svg << "</g>\n<g class=\"ref\">\n";
  for (const auto& [name, q] : refs) {
    const Eigen::Vector2d s = vp.Map(q);
    svg << "<rect x=\"" << C(s.x() - cam_r) << "\" y=\"" << C(s.y() - cam_r)
        << "\" width=\"" << C(2 * cam_r) << "\" height=\"" << C(2 * cam_r)
        << "\"><title>reference " << Esc(name) << "</title></rect>\n";
  }
  svg << "</g>\n";
}

// The model's cameras: a dot of radius `cam_r` with a stroke along the
// viewing direction (`span`: the drawing's extent), coloured by community.
void DrawTopViewCameras(
    const std::vector<std::pair<const Image*, Eigen::Vector2d>>& cams,
    const TopViewFrame& frame, const Viewport& vp, double span, double cam_r,
    const std::map<std::string, int>& community, std::ostringstream& svg) {
  svg << "<g class=\"cams\">\n";
  for (const auto& [image, q] : cams) {
    const Eigen::Vector2d s = vp.Map(q);
    Eigen::Vector2d dir = frame.ProjectDirection(
        image->cam_from_world.rotation.inverse() * Eigen::Vector3d::UnitZ());
    const Eigen::Vector2d tip = vp.Map(q + 0.035 * span * dir);
    auto it = community.find(image->name);
    const std::string color =
        it == community.end() ? "#1f77b4" : CommunityColor(it->second);
    svg << "<g stroke=\"" << color << "\" fill=\"" << color << "\">"
        << Line(s, tip, "") << "<circle cx=\"" << C(s.x()) << "\" cy=\""
        << C(s.y()) << "\" r=\"" << C(cam_r) << "\"><title>"
        << Esc(StrCat(image->name, " (image ", image->image_id, ")",
                      it == community.end()
                          ? ""
                          : StrCat(", community ", it->second)))
        << "</title></circle></g>\n";
  }
}

// The top view's caption: what is drawn (cameras, `drawn` points, coloured
// by community or not, seen from above or not) and how the reference was
// aligned.
std::string TopViewCaption(const ReportInput& in, const Reconstruction& model,
                           bool by_community, size_t drawn, bool along_up,
                           bool aligned, size_t num_common) {
  std::ostringstream out;
  out << model.NumRegImages() << " cameras (dots with their viewing "
      << "direction" << (by_community ? ", coloured by community" : "")
      << ") and " << drawn << " of " << model.NumPoints3D()
      << " points, "
      << (along_up
              ? "seen from above (looking down the cameras' mean up "
                "direction)."
              : "projected onto the plane of the two main directions of the "
                "camera centres (the cameras disagree on which way is up).");
  if (in.reference) {
    if (aligned) {
      out << " Grey squares: the reference cameras after a robust "
             "similarity alignment on "
          << num_common
          << " common images; a thin line joins each camera to its "
             "reference.";
    } else {
      out << " The reference could not be aligned (" << num_common
          << " common images).";
    }
  }
  return out.str();
}

std::string ModelSection(const ReportInput& in, const Reconstruction& model,
                         const std::string& title,
                         const ReportOptions& options) {
  if (model.images.empty()) return "";
  const TopViewFrame frame = ComputeTopViewFrame(model);
  const std::map<std::string, int> community = CommunityByName(in.hierarchy);

  Bounds b;
  std::vector<std::pair<const Image*, Eigen::Vector2d>> cams;
  for (const auto& [id, image] : model.images) {
    cams.emplace_back(&image, frame.Project(image.ProjectionCenter()));
    b.Add(cams.back().second);
  }
  // Reference cameras moved into the model's frame.
  std::vector<std::pair<std::string, Eigen::Vector2d>> refs;
  Sim3d model_from_reference;
  size_t num_common = 0;
  bool aligned = false;
  if (in.reference) {
    aligned = AlignReferenceToModel(model, *in.reference,
                                    &model_from_reference, &num_common);
    if (aligned) {
      for (const auto& [id, image] : in.reference->images) {
        refs.emplace_back(image.name, frame.Project(model_from_reference *
                                                    image.ProjectionCenter()));
        b.Add(refs.back().second);
      }
    }
  }
  // Points: evenly subsampled, bounded by robust percentiles.
  const size_t step = std::max<size_t>(
      1, (model.NumPoints3D() + options.max_points - 1) / options.max_points);
  std::vector<std::pair<Eigen::Vector2d, const Point3D*>> points;
  size_t k = 0;
  for (const auto& [id, p] : model.points3D) {
    if (k++ % step != 0) continue;
    points.emplace_back(frame.Project(p.xyz), &p);
  }
  if (!points.empty()) {
    std::vector<double> xs, ys;
    for (const auto& [q, p] : points) {
      xs.push_back(q.x());
      ys.push_back(q.y());
    }
    b.Add({Percentile(xs, 0.02), Percentile(ys, 0.02)});
    b.Add({Percentile(xs, 0.98), Percentile(ys, 0.98)});
  }
  Bounds clip = b;
  clip.Expand(0.04);
  const Viewport vp = FitViewport(clip.min_x, clip.max_x, clip.min_y,
                                  clip.max_y, options.drawing_width, 320, 760,
                                  20);
  const double span = std::max(clip.max_x - clip.min_x, clip.max_y - clip.min_y);

  std::ostringstream svg;
  svg << "<svg class=\"drawing\" viewBox=\"0 0 " << C(vp.width) << ' '
      << C(vp.height) << "\" role=\"img\" aria-label=\"top view\">\n";
  svg << "<rect class=\"bg\" width=\"" << C(vp.width) << "\" height=\""
      << C(vp.height) << "\"/>\n";
  const size_t drawn = DrawTopViewPoints(points, clip, vp, svg);
  const double cam_r = std::clamp(
      50.0 / std::sqrt(static_cast<double>(cams.size())), 2.5, 6.0);
  DrawReferenceCameras(model, frame, refs, vp, cam_r, svg);
  DrawTopViewCameras(cams, frame, vp, span, cam_r, community, svg);
  svg << "</g>\n</svg>\n";

  std::ostringstream out;
  out << "<h2>" << Esc(title) << "</h2>\n<p class=\"caption\">"
      << TopViewCaption(in, model, !community.empty(), drawn,
                        frame.along_up, aligned, num_common);
  out << "</p>\n<div class=\"figure\">\n" << svg.str() << "</div>\n";
  return out.str();
}

// Stage names of the summary's timings, in pipeline order.
const std::vector<std::pair<std::string, std::string>>& MapperStageNames() {
  static const std::vector<std::pair<std::string, std::string>> names = {
      {"read_database", "read database"},
      {"build_hierarchy", "build hierarchy (communities, skeleton, leaves)"},
      {"filter_databases", "write filtered databases"},
      {"scaffold", "scaffold (colmap mapper on the skeleton)"},
      {"retriangulation", "scaffold segments refined (sequence pairs)"},
      {"attach", "attach leaves (colmap mapper)"},
      {"global_bundle_adjustment", "global bundle adjustment"}};
  return names;
}

std::string StageSection(const ReportInput& in, const ReportOptions& options) {
  std::vector<ReportStage> stages = in.stages;
  double mapper_total = -1;
  if (in.summary.is_object() && in.summary.contains("timings")) {
    const Json& t = in.summary["timings"];
    std::set<std::string> known;
    for (const auto& [key, label] : MapperStageNames()) {
      known.insert(key);
      if (t.contains(key) && t[key].is_number()) {
        stages.push_back({label, t[key].get<double>(), ""});
      }
    }
    for (const auto& [key, value] : t.items()) {
      if (key == "total") {
        mapper_total = value.get<double>();
      } else if (!known.count(key) && value.is_number()) {
        stages.push_back({key, value.get<double>(), ""});
      }
    }
  }
  if (stages.empty()) return "";
  double max_seconds = 0, sum = 0;
  for (const ReportStage& s : stages) {
    max_seconds = std::max(max_seconds, s.seconds);
    sum += s.seconds;
  }
  const double width = options.drawing_width;
  bool any_note = false;
  for (const ReportStage& s : stages) any_note |= !s.note.empty();
  const double label_w = 390, bar_x = label_w + 10;
  const double bar_w = width - bar_x - (any_note ? 340 : 110);
  const double row_h = 26;
  const double height = row_h * stages.size() + 12;
  std::ostringstream svg;
  svg << "<svg class=\"drawing stages\" viewBox=\"0 0 " << C(width) << ' '
      << C(height) << "\" role=\"img\" aria-label=\"stage times\">\n";
  for (size_t i = 0; i < stages.size(); ++i) {
    const ReportStage& s = stages[i];
    const double y = 6 + i * row_h;
    const double w =
        max_seconds > 0 ? std::max(1.0, bar_w * s.seconds / max_seconds) : 1;
    svg << "<text class=\"lbl\" x=\"" << C(label_w) << "\" y=\""
        << C(y + 17) << "\">" << Esc(s.name) << "</text>"
        << "<rect class=\"bar\" x=\"" << C(bar_x) << "\" y=\"" << C(y + 4)
        << "\" width=\"" << C(w) << "\" height=\"" << C(row_h - 8)
        << "\"/><text class=\"val\" x=\"" << C(bar_x + w + 6) << "\" y=\""
        << C(y + 17) << "\">" << Seconds(s.seconds)
        << (s.note.empty() ? "" : " (" + Esc(s.note) + ")") << "</text>\n";
  }
  svg << "</svg>\n";
  std::string total = StrCat("sum of the stages: ", Seconds(sum));
  if (mapper_total >= 0) {
    total += StrCat("; mapper wall time ", Seconds(mapper_total));
  }
  return "<h2>Time of each stage</h2>\n<div class=\"figure\">\n" + svg.str() +
         "</div>\n<p class=\"caption\">" + total + ".</p>\n";
}

std::string ModelsTable(const ReportInput& in) {
  if (!in.summary.is_object() || !in.summary.contains("models") ||
      in.summary["models"].size() < 2) {
    return "";
  }
  std::string out =
      "<h2>Models</h2>\n<table class=\"grid\">\n<tr><th>folder</th><th>"
      "images</th><th>registered</th><th>points</th><th>mean track "
      "length</th><th>mean reprojection error</th></tr>\n";
  for (const Json& m : in.summary["models"]) {
    out += "<tr><td>" + Esc(JStr(m, "path")) + "</td><td>" +
           JStr(m, "component_images") + "</td><td>" +
           JStr(m, "registered_images") + "</td><td>" + JStr(m, "points3D") +
           "</td><td>" + JNum(m, "mean_track_length", 2) + "</td><td>" +
           JNum(m, "mean_reprojection_error", 3) + " px</td></tr>\n";
  }
  return out + "</table>\n";
}

std::string SkippedSection(const ReportInput& in) {
  if (in.skipped_files.empty()) return "";
  std::string out = StrCat("<h2>Skipped input files (",
                           in.skipped_files.size(),
                           ")</h2>\n<table class=\"grid\">\n<tr><th>file</th>"
                           "<th>reason</th></tr>\n");
  for (const auto& [name, reason] : in.skipped_files) {
    out += "<tr><td>" + Esc(name) + "</td><td>" + Esc(reason) + "</td></tr>\n";
  }
  return out + "</table>\n";
}

std::string FactsTable(const ReportInput& in) {
  std::vector<std::pair<std::string, std::string>> facts = in.facts;
  const Json& s = in.summary;
  for (const char* key : {"image_path", "database_path", "work_path"}) {
    if (s.is_object() && s.contains(key)) {
      std::string label = key;
      std::replace(label.begin(), label.end(), '_', ' ');
      facts.emplace_back(label, JStr(s, key));
    }
  }
  facts.emplace_back("report written", NowText());
  std::string out = "<table class=\"kv facts\">\n";
  for (const auto& [k, v] : facts) {
    out += "<tr><th>" + Esc(k) + "</th><td>" + Esc(v) + "</td></tr>\n";
  }
  return out + "</table>\n";
}

const char* kStyle = R"CSS(
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;
 margin:0;background:#f4f5f7;color:#1d2330;}
main{max-width:1180px;margin:0 auto;padding:18px 28px 40px;}
h1{font-size:26px;margin:10px 0 6px;} h2{font-size:19px;margin:28px 0 8px;
 border-bottom:2px solid #dde1e8;padding-bottom:4px;}
.cards{display:grid;grid-template-columns:repeat(auto-fill,minmax(170px,1fr));gap:10px;}
.card{background:#fff;border-radius:8px;padding:10px 14px;box-shadow:0 1px 2px rgba(0,0,0,.12);}
.card .value{font-size:22px;font-weight:600;} .card .label{color:#5a6475;font-size:13px;}
.card .detail{color:#7a8495;font-size:12px;margin-top:3px;}
table{border-collapse:collapse;background:#fff;font-size:14px;}
table.grid th,table.grid td{border:1px solid #dde1e8;padding:4px 9px;text-align:left;}
table.grid th{background:#eef0f4;} table.kv th{text-align:left;padding:3px 14px 3px 8px;
 color:#5a6475;font-weight:500;} table.kv td{padding:3px 8px;}
table.facts{font-size:13px;}
tr.rejected td{color:#b02020;}
.badge{display:inline-block;padding:2px 10px;border-radius:12px;font-weight:600;font-size:14px;}
.badge.ok{background:#d8f3dc;color:#1b6b2f;} .badge.bad{background:#fde2e1;color:#a61b1b;}
.badge.none{background:#e9ecf1;color:#5a6475;} .reason{color:#7a2020;font-size:13px;}
td.time{white-space:nowrap;}
.tbar{display:inline-block;height:10px;background:#5b7bd5;vertical-align:middle;}
.caption{color:#4a5465;font-size:14px;margin:4px 0 8px;}
.figure{background:#fff;border-radius:8px;box-shadow:0 1px 2px rgba(0,0,0,.12);padding:6px;}
svg.drawing{width:100%;height:auto;display:block;}
svg .bg{fill:#ffffff;}
svg .note{font-size:13px;fill:#6a7485;}
.e-leaf line{stroke:#b8bec9;stroke-width:1;}
.e-intra line{stroke-width:2;stroke-opacity:.85;}
.e-bridge line{stroke:#1d2330;stroke-width:3;}
.e-rejected line{stroke:#d62728;stroke-width:1.6;stroke-dasharray:6 4;}
.e-label text{font-size:11px;fill:#b01818;text-anchor:middle;paint-order:stroke;
 stroke:#fff;stroke-width:3px;}
.nodes circle.skel{stroke:#1d2330;stroke-width:1.5;}
.nodes circle.leaf{stroke:#fff;stroke-width:.8;}
.nodes circle.unreg{stroke-width:1.5;stroke-dasharray:2 2;}
.points path{stroke-width:2.2;stroke-linecap:round;fill:none;}
.cams line{stroke-width:1.6;} .cams circle{stroke:#fff;stroke-width:.8;}
.ref rect{fill:none;stroke:#555;stroke-width:1.4;}
.ref-links line{stroke:#ff7f0e;stroke-width:1;stroke-opacity:.55;}
svg.stages .lbl{font-size:14px;text-anchor:end;fill:#1d2330;}
svg.stages .val{font-size:13px;fill:#4a5465;} svg.stages .bar{fill:#5b7bd5;}
.toggles>label{margin-right:16px;font-size:14px;cursor:pointer;user-select:none;}
.toggles>input{vertical-align:middle;}
.toggles .figure{margin-top:6px;}
.sw{display:inline-block;width:22px;height:0;vertical-align:middle;margin:0 5px 0 2px;}
.sw-leaf{border-top:2px solid #b8bec9;} .sw-intra{border-top:3px solid hsl(0,70%,45%);}
.sw-bridge{border-top:4px solid #1d2330;} .sw-rejected{border-top:2px dashed #d62728;}
#t-leaf:not(:checked)~.figure .e-leaf{display:none;}
#t-intra:not(:checked)~.figure .e-intra{display:none;}
#t-bridge:not(:checked)~.figure .e-bridge{display:none;}
#t-rejected:not(:checked)~.figure .e-rejected{display:none;}
#t-label:not(:checked)~.figure .e-label{display:none;}
details{margin-top:12px;} summary{cursor:pointer;font-size:15px;margin-bottom:6px;}
footer{color:#7a8495;font-size:12px;margin-top:30px;}
)CSS";

}  // namespace

std::string RenderReportHtml(const ReportInput& in,
                             const ReportOptions& options) {
  options.Check();
  std::string body;
  body += "<h1>" + Esc(in.title) + "</h1>\n";
  body += FactsTable(in);
  if (in.evaluation.is_object() && !in.evaluation.empty()) {
    body += "<p>Result: " + VerdictBadge(in.evaluation) + "</p>\n";
  }
  body += ComparisonSection(in);
  body += SummarySection(in);
  body += EvaluationSection(in);
  body += ViewGraphSection(in, options);
  body += BridgeTable(in, options);
  if (in.model) {
    body += ModelSection(in, *in.model, "Cameras and points (top view)",
                         options);
  }
  for (const ReportModelView& view : in.extra_views) {
    body += ModelSection(in, view.model, view.title, options);
  }
  body += StageSection(in, options);
  body += ModelsTable(in);
  body += SkippedSection(in);
  body += "<footer>Written by HiSfM. Self-contained file: no scripts, no "
          "network access.</footer>\n";
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta "
         "charset=\"utf-8\">\n<meta name=\"viewport\" "
         "content=\"width=device-width, initial-scale=1\">\n<title>" +
         Esc(in.title) + "</title>\n<style>" + kStyle +
         "</style>\n</head>\n<body>\n<main>\n" + body +
         "</main>\n</body>\n</html>\n";
}

void WriteReport(const ReportInput& input, const std::string& html_path,
                 const ReportOptions& options) {
  WriteFileAtomically(html_path, RenderReportHtml(input, options));
}

ReportInput ReadMapperReportInput(const std::string& output_path) {
  const std::string summary_path = output_path + "/hisfm_summary.json";
  CheckFileReadable(summary_path, "mapper summary");
  ReportInput in;
  try {
    in.summary = Json::parse(ReadTextFile(summary_path));
  } catch (const Json::exception& e) {
    throw Error(StrCat("cannot parse ", summary_path, ": ", e.what()));
  }
  const std::string problem = FindSummaryJsonProblem(in.summary);
  ThrowUnless(problem.empty(),
              StrCat("mapper summary ", summary_path, ": ", problem));
  std::string model_dir = output_path + "/0";
  if (in.summary.contains("models") && !in.summary["models"].empty()) {
    model_dir = output_path + "/" + JStr(in.summary["models"][0], "path");
  }
  if (HasModel(model_dir)) {
    in.model = ReadModel(model_dir);
  }
  const std::string work = JStr(in.summary, "work_path");
  const std::string hierarchy_path = work + "/view_graph.json";
  if (!work.empty() && fs::exists(hierarchy_path)) {
    // An optional part: a broken one is left out, with a warning.
    try {
      in.hierarchy = Json::parse(ReadTextFile(hierarchy_path));
      const std::string hierarchy_problem =
          FindHierarchyJsonProblem(in.hierarchy);
      if (!hierarchy_problem.empty()) {
        HISFM_LOG_WARN("view graph left out of the report: {}: {}",
                       hierarchy_path, hierarchy_problem);
        in.hierarchy = nullptr;
      }
    } catch (const Json::exception& e) {
      HISFM_LOG_WARN("view graph left out of the report: cannot parse {}: {}",
                     hierarchy_path, e.what());
      in.hierarchy = nullptr;
    }
  }
  in.facts.emplace_back("output", fs::absolute(output_path).string());
  return in;
}

}  // namespace hisfm
