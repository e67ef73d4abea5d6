#include "fuzz_checks.h"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <unordered_map>
#include <unordered_set>

#include "hisfm/io/database.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/io/model.h"
#include "hisfm/io/model_validation.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace fuzz {

void Fail(const std::string& what) {
  std::fprintf(stderr, "fuzz invariant broken: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

const std::string& ScratchFolder() {
  // Never destroyed: the exit handler that removes the folder reads it.
  static const std::string* const folder = [] {
    const std::string base =
        fs::is_directory("/dev/shm") && access("/dev/shm", W_OK) == 0
            ? "/dev/shm"
            : fs::temp_directory_path().string();
    // Folders of earlier runs that crashed (no exit handler ran).
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(base, ec)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("hisfm-fuzz-", 0) != 0) continue;
      const long pid = std::atol(name.c_str() + 11);
      if (pid > 0 && kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
        fs::remove_all(entry.path(), ec);
      }
    }
    const auto* path = new std::string(
        StrCat(base, "/hisfm-fuzz-", static_cast<long>(getpid())));
    fs::remove_all(*path);
    fs::create_directories(*path);
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(ScratchFolder(), ec);
    });
    // Readers log at info level; the fuzzer's output stays readable.
    SetLogLevel("off");
    return path;
  }();
  return *folder;
}

std::string ScratchSubfolder(const std::string& name) {
  const std::string path = ScratchFolder() + "/" + name;
  fs::create_directories(path);
  return path;
}

void WriteBytes(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data),
            static_cast<std::streamsize>(size));
  if (!out.good()) Fail("cannot write " + path);
}

namespace {

// Reads everything without validation: only hisfm::Error may come out.
void ReadUnvalidated(const std::string& path) {
  try {
    Database db(path);
    db.ReadCameras();
    const std::vector<DatabaseImage> images = db.ReadImages();
    db.ReadNumKeypoints();
    for (const DatabaseImage& image : images) {
      try {
        db.ReadKeypoints(image.image_id);
        db.ReadDescriptors(image.image_id);
      } catch (const Error&) {
      }
    }
    for (const VerifiedPair& p : db.ReadVerifiedPairs(1)) {
      try {
        db.ReadTwoViewGeometry(p.pair.image_id1, p.pair.image_id2);
        db.ReadMatches(p.pair.image_id1, p.pair.image_id2);
      } catch (const Error&) {
      }
    }
  } catch (const Error&) {
  }
}

void CheckValidated(const std::string& path) {
  Database db(path);
  std::unordered_set<CameraId> cameras;
  for (const DatabaseCamera& c : db.ReadCameras()) {
    if (static_cast<int>(c.params.size()) != CameraModelNumParams(c.model_id) ||
        c.width == 0 || c.height == 0) {
      Fail(StrCat("camera ", c.camera_id, " passed validation"));
    }
    cameras.insert(c.camera_id);
  }
  const std::vector<DatabaseImage> images = db.ReadImages();
  const std::unordered_map<ImageId, size_t> num_keypoints =
      db.ReadNumKeypoints();
  std::unordered_map<ImageId, size_t> rows;
  std::unordered_set<std::string> names;
  for (const DatabaseImage& image : images) {
    if (!cameras.count(image.camera_id) || !names.insert(image.name).second) {
      Fail(StrCat("image ", image.image_id, " passed validation"));
    }
    const Keypoints keypoints = db.ReadKeypoints(image.image_id);
    const auto it = num_keypoints.find(image.image_id);
    const size_t expected = it == num_keypoints.end() ? 0 : it->second;
    if (static_cast<size_t>(keypoints.rows()) != expected ||
        !keypoints.allFinite()) {
      Fail(StrCat("keypoints of image ", image.image_id, ": ", keypoints.rows(),
                  " rows, ", expected, " counted"));
    }
    rows[image.image_id] = expected;
    const Descriptors descriptors = db.ReadDescriptors(image.image_id);
    if (descriptors.rows() > 0 &&
        (static_cast<size_t>(descriptors.rows()) != expected ||
         descriptors.cols() != 128)) {
      Fail(StrCat("descriptors of image ", image.image_id));
    }
  }
  auto check_matches = [&](const ImagePair& pair,
                           const std::vector<FeatureMatch>& matches) {
    if (!rows.count(pair.image_id1) || !rows.count(pair.image_id2) ||
        pair.image_id1 == pair.image_id2) {
      Fail(StrCat("pair ", pair.image_id1, "-", pair.image_id2,
                  " passed validation"));
    }
    for (const FeatureMatch& m : matches) {
      if (m.idx1 >= rows[pair.image_id1] || m.idx2 >= rows[pair.image_id2]) {
        Fail(StrCat("match index out of range in pair ", pair.image_id1, "-",
                    pair.image_id2));
      }
    }
  };
  const std::vector<VerifiedPair> pairs = db.ReadVerifiedPairs(1);
  std::vector<ImagePair> all;
  for (const VerifiedPair& p : pairs) {
    const TwoViewGeometry g =
        db.ReadTwoViewGeometry(p.pair.image_id1, p.pair.image_id2);
    if (g.inlier_matches.size() != p.num_inliers || g.config < 0 ||
        g.config > 8 || !g.F.allFinite() || !g.E.allFinite() ||
        !g.H.allFinite() || !g.qvec.allFinite() || !g.tvec.allFinite()) {
      Fail(StrCat("two-view geometry of ", p.pair.image_id1, "-",
                  p.pair.image_id2));
    }
    check_matches(p.pair, g.inlier_matches);
    check_matches(p.pair, db.ReadMatches(p.pair.image_id1, p.pair.image_id2));
    all.push_back(p.pair);
  }
  size_t seen = 0;
  db.ForEachInlierMatches(
      all, [&](const ImagePair& pair, FeatureMatchSpan matches) {
        if (matches.size() !=
            db.ReadInlierMatches(pair.image_id1, pair.image_id2).size()) {
          Fail("ForEachInlierMatches disagrees with ReadInlierMatches");
        }
        ++seen;
      });
  if (seen != all.size()) Fail("ForEachInlierMatches skipped pairs");
  // What colmap gets: hisfm's filtered copy, which must validate too.
  const std::string copy = ScratchFolder() + "/filtered.db";
  fs::remove(copy);
  FilteredDatabaseOptions options;
  options.copy_descriptors = true;
  options.copy_matches = true;
  WriteFilteredDatabase(path, copy, all, options);
  const std::vector<DatabaseProblem> problems = ValidateDatabase(copy);
  if (!problems.empty()) {
    Fail("the filtered copy of a valid database is invalid: " +
         FormatDatabaseProblem(problems[0]));
  }
}

}  // namespace

void CheckDatabase(const std::string& path, bool intact_file) {
  ReadUnvalidated(path);
  std::vector<DatabaseProblem> problems;
  try {
    problems = ValidateDatabase(path);
  } catch (const Error&) {
    return;  // Not a COLMAP database at all: refused as such.
  }
  for (const DatabaseProblem& p : problems) {
    if (p.table.empty() || p.message.empty() ||
        FormatDatabaseProblem(p).find('\n') != std::string::npos) {
      Fail("a problem that is not one line: " + FormatDatabaseProblem(p));
    }
  }
  if (!problems.empty()) return;
  try {
    CheckValidated(path);
  } catch (const Error& e) {
    if (intact_file) {
      Fail(StrCat("a reader failed on a validated database: ", e.what()));
    }
  } catch (const std::exception& e) {
    Fail(StrCat("a reader failed on a validated database: ", e.what()));
  }
}

void CheckModel(const std::string& path, const std::string* binary_files) {
  Reconstruction model;
  try {
    model = ReadModelUnvalidated(path);
  } catch (const Error&) {
    return;  // Malformed: refused in one line.
  }
  const std::string out = ScratchFolder() + "/written";
  fs::remove_all(out);
  fs::create_directories(out);
  try {
    WriteModelBinary(model, out);
    if (binary_files) {
      const char* names[] = {"cameras.bin", "images.bin", "points3D.bin"};
      for (int k = 0; k < 3; ++k) {
        if (ReadTextFile(out + "/" + names[k]) != binary_files[k]) {
          Fail(StrCat(names[k], " read and written is not byte-identical"));
        }
      }
    }
  } catch (const std::exception& e) {
    Fail(StrCat("a parsed model cannot be written: ", e.what()));
  }
  if (!ValidateModel(model).empty()) return;
  try {
    ReadModel(path);
    fs::remove_all(out);
    fs::create_directories(out);
    WriteModelText(model, out);
    const Reconstruction text = ReadModel(out);
    if (text.cameras.size() != model.cameras.size() ||
        text.images.size() != model.images.size() ||
        text.points3D.size() != model.points3D.size() ||
        text.NumObservations() != model.NumObservations()) {
      Fail("a text round trip changed a valid model");
    }
  } catch (const std::exception& e) {
    Fail(StrCat("a valid model fails to be read, or read back from text: ",
                e.what()));
  }
}

}  // namespace fuzz
}  // namespace hisfm
