#include "hisfm/io/model_validation.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "hisfm/util/error.h"

namespace hisfm {

std::string FormatModelProblem(const ModelProblem& problem) {
  return StrCat(problem.file, ", ", problem.id, ": ", problem.message);
}

void ModelValidationOptions::Check() const {
  HISFM_CHECK_OPTION(max_problems, max_problems >= 0, ">= 0");
}

namespace {

class Problems {
 public:
  explicit Problems(int limit) : limit_(static_cast<size_t>(limit)) {}
  void Add(const char* file, const std::string& id,
           const std::string& message) {
    if (!Full()) problems_.push_back({file, id, message});
  }
  bool Full() const { return limit_ > 0 && problems_.size() >= limit_; }
  std::vector<ModelProblem> Take() { return std::move(problems_); }

 private:
  size_t limit_;
  std::vector<ModelProblem> problems_;
};

template <typename Vector>
bool AllFinite(const Vector& v) {
  for (int k = 0; k < v.size(); ++k) {
    if (!std::isfinite(v[k])) return false;
  }
  return true;
}

std::string VectorText(const double* values, int n) {
  std::string out = "(";
  for (int k = 0; k < n; ++k) {
    out += StrCat(k > 0 ? ", " : "", values[k]);
  }
  return out + ")";
}

void CheckCameras(const Reconstruction& model, Problems* out) {
  for (const auto& [camera_id, camera] : model.cameras) {
    if (out->Full()) return;
    const std::string id = StrCat("camera ", camera_id);
    if (camera.width == 0 || camera.height == 0) {
      out->Add("cameras", id,
               StrCat("size ", camera.width, " x ", camera.height,
                      " is not a positive image size"));
    }
    const int num_params = CameraModelNumParams(camera.model_id);
    if (num_params < 0 ||
        static_cast<int>(camera.params.size()) != num_params) {
      out->Add("cameras", id,
               StrCat("model id ", camera.model_id, " with ",
                      camera.params.size(), " parameters"));
      continue;
    }
    const auto bad = std::find_if(camera.params.begin(), camera.params.end(),
                                  [](double p) { return !std::isfinite(p); });
    if (bad != camera.params.end()) {
      out->Add("cameras", id,
               StrCat("parameter ", bad - camera.params.begin(), " is ", *bad));
      continue;
    }
    for (int k = 0; k < CameraModelNumFocalLengths(camera.model_id); ++k) {
      if (!(camera.params[k] > 0)) {
        out->Add("cameras", id,
                 StrCat("focal length ", camera.params[k], " is not positive"));
        break;
      }
    }
  }
}

void CheckImages(const Reconstruction& model, Problems* out) {
  std::unordered_map<std::string, ImageId> names;
  names.reserve(model.images.size());
  for (const auto& [image_id, image] : model.images) {
    if (out->Full()) return;
    const std::string id = StrCat("image ", image_id);
    if (model.cameras.count(image.camera_id) == 0) {
      out->Add("images", id,
               StrCat("refers to camera ", image.camera_id,
                      ", which is not in the model"));
    }
    const Eigen::Quaterniond& q = image.cam_from_world.rotation;
    const double qvec[4] = {q.w(), q.x(), q.y(), q.z()};
    if (!AllFinite(q.coeffs()) || !(q.coeffs().squaredNorm() > 1e-24)) {
      out->Add("images", id,
               StrCat("rotation quaternion ", VectorText(qvec, 4),
                      " is not a rotation"));
    }
    const Eigen::Vector3d& t = image.cam_from_world.translation;
    if (!AllFinite(t)) {
      out->Add(
          "images", id,
          StrCat("translation ", VectorText(t.data(), 3), " is not finite"));
    }
    if (image.name.empty()) {
      out->Add("images", id, "name is empty");
    } else if (std::any_of(image.name.begin(), image.name.end(), [](char c) {
                 return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
               })) {
      out->Add("images", id,
               "name contains a line break or another control character");
    } else if (image.name.front() == ' ' || image.name.back() == ' ') {
      // The text format's name is the rest of its line, trimmed.
      out->Add("images", id, "name begins or ends with a space");
    } else if (const auto [it, inserted] = names.emplace(image.name, image_id);
               !inserted) {
      out->Add("images", id,
               StrCat("name '", image.name, "' is also the name of image ",
                      it->second));
    }
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      const Point2D& point = image.points2D[k];
      if (!AllFinite(point.xy)) {
        out->Add("images", id, StrCat("point2D ", k, " is not finite"));
        break;
      }
      if (point.point3D_id != kInvalidPoint3DId &&
          model.points3D.count(point.point3D_id) == 0) {
        out->Add("images", id,
                 StrCat("point2D ", k, " observes point ", point.point3D_id,
                        ", which is not in points3D"));
        break;
      }
    }
  }
}

void CheckPoints(const Reconstruction& model, Problems* out) {
  for (const auto& [point3D_id, point] : model.points3D) {
    if (out->Full()) return;
    const std::string id = StrCat("point ", point3D_id);
    if (point3D_id == kInvalidPoint3DId) {
      out->Add("points3D", id, "id 2^64 - 1 means 'no point' in COLMAP models");
    }
    if (!AllFinite(point.xyz) || !std::isfinite(point.error)) {
      out->Add("points3D", id,
               StrCat("position ", VectorText(point.xyz.data(), 3),
                      " or error ", point.error, " is not finite"));
    }
    for (size_t k = 0; k < point.track.size(); ++k) {
      const TrackElement& element = point.track[k];
      const auto image = model.images.find(element.image_id);
      if (image == model.images.end()) {
        out->Add("points3D", id,
                 StrCat("track element ", k, " names image ", element.image_id,
                        ", which is not in the model"));
        break;
      }
      const std::vector<Point2D>& points2D = image->second.points2D;
      if (element.point2D_idx >= points2D.size()) {
        out->Add("points3D", id,
                 StrCat("track element ", k, " names point2D ",
                        element.point2D_idx, " of image ", element.image_id,
                        ", which has ", points2D.size()));
        break;
      }
      const Point3DId observed = points2D[element.point2D_idx].point3D_id;
      if (observed != point3D_id) {
        out->Add(
            "points3D", id,
            StrCat("track element ", k, " names point2D ", element.point2D_idx,
                   " of image ", element.image_id, ", which observes ",
                   observed == kInvalidPoint3DId ? std::string("no point")
                                                 : StrCat("point ", observed)));
        break;
      }
    }
  }
}

}  // namespace

std::vector<ModelProblem> ValidateModel(const Reconstruction& model,
                                        const ModelValidationOptions& options) {
  options.Check();
  Problems out(options.max_problems);
  CheckCameras(model, &out);
  CheckImages(model, &out);
  CheckPoints(model, &out);
  return out.Take();
}

void RequireValidModel(const Reconstruction& model, const std::string& path) {
  ModelValidationOptions options;
  options.max_problems = 1;
  const std::vector<ModelProblem> problems = ValidateModel(model, options);
  if (problems.empty()) return;
  throw Error(StrCat("invalid COLMAP model ", path, ": ",
                     FormatModelProblem(problems[0]),
                     " (hisfm check_model lists every problem)"));
}

}  // namespace hisfm
