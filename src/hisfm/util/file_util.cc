#include "hisfm/util/file_util.h"

#include <unistd.h>

#include <deque>
#include <fstream>
#include <random>
#include <sstream>

#include "hisfm/util/error.h"

namespace fs = std::filesystem;

namespace hisfm {

void CheckFileReadable(const std::string& path, const std::string& what) {
  std::error_code ec;
  ThrowUnless(fs::exists(path, ec), StrCat(what, " does not exist: ", path));
  ThrowUnless(fs::is_regular_file(path, ec),
              StrCat(what, " is not a file: ", path));
  ThrowUnless(access(path.c_str(), R_OK) == 0,
              StrCat(what, " is not readable: ", path));
}

void CheckDirectoryExists(const std::string& path, const std::string& what) {
  std::error_code ec;
  ThrowUnless(fs::is_directory(path, ec),
              StrCat(what, " is not an existing folder: ", path));
}

bool IsMissingOrEmptyDirectory(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return true;
  return fs::is_directory(path, ec) && fs::is_empty(path, ec);
}

std::string NormalizePath(const std::string& path) {
  std::error_code ec;
  fs::path normal = fs::weakly_canonical(fs::absolute(path), ec);
  if (ec) normal = fs::absolute(path).lexically_normal();
  std::string out = normal.string();
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  return out;
}

bool IsSameOrInside(const std::string& path, const std::string& folder) {
  const std::string p = NormalizePath(path);
  const std::string f = NormalizePath(folder);
  if (p == f) return true;
  const std::string prefix = f == "/" ? f : f + "/";
  return p.compare(0, prefix.size(), prefix) == 0;
}

namespace {
constexpr char kWorkMarker[] = ".hisfm_work";
}  // namespace

void PrepareWorkDirectory(const std::string& path,
                          const std::string& legacy_file) {
  std::error_code ec;
  if (fs::exists(path, ec)) {
    ThrowUnless(fs::is_directory(path, ec),
                StrCat("work path is a file, not a folder: ", path));
    ThrowUnless(fs::is_empty(path, ec) ||
                    fs::exists(fs::path(path) / kWorkMarker, ec) ||
                    (!legacy_file.empty() &&
                     fs::is_regular_file(fs::path(path) / legacy_file, ec)),
                StrCat("work folder is not empty and was not made by hisfm: ",
                       path, " (choose another folder)"));
    fs::remove_all(path, ec);
    ThrowUnless(!ec, StrCat("cannot clear ", path, ": ", ec.message()));
  }
  fs::create_directories(path, ec);
  ThrowUnless(!ec, StrCat("cannot create work folder ", path, ": ",
                          ec.message()));
  std::ofstream marker(fs::path(path) / kWorkMarker);
  marker << "Intermediate files of a hisfm run; hisfm empties this folder "
            "when it runs again with the same work path.\n";
  ThrowUnless(marker.good(), StrCat("cannot write in work folder ", path));
}

namespace {
std::string RandomSuffix() {
  std::random_device rd;
  std::ostringstream out;
  out << std::hex << rd() << getpid();
  return out.str();
}
}  // namespace

AtomicDirectory::AtomicDirectory(std::string final_path)
    : final_path_(fs::absolute(final_path).lexically_normal().string()) {
  if (!final_path_.empty() && final_path_.back() == '/') final_path_.pop_back();
  ThrowUnless(IsMissingOrEmptyDirectory(final_path_),
              StrCat("output folder is not empty: ", final_path_));
  const fs::path parent = fs::path(final_path_).parent_path();
  std::error_code ec;
  fs::create_directories(parent, ec);
  ThrowUnless(!ec, StrCat("cannot create folder ", parent.string(), ": ",
                          ec.message()));
  temp_path_ = (parent / ("." + fs::path(final_path_).filename().string() +
                          ".tmp-" + RandomSuffix()))
                   .string();
  fs::create_directories(temp_path_, ec);
  ThrowUnless(!ec, StrCat("cannot create folder ", temp_path_, ": ",
                          ec.message()));
}

AtomicDirectory::~AtomicDirectory() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_path_, ec);
  }
}

void AtomicDirectory::Commit() {
  std::error_code ec;
  if (fs::exists(final_path_, ec)) fs::remove(final_path_, ec);
  fs::rename(temp_path_, final_path_, ec);
  ThrowUnless(!ec, StrCat("cannot rename ", temp_path_, " to ", final_path_,
                          ": ", ec.message()));
  committed_ = true;
}

void CheckReplaceableFile(const std::string& path) {
  std::error_code ec;
  ThrowUnless(!fs::is_directory(path, ec),
              StrCat("output is a folder, not a file: ", path));
  if (fs::is_regular_file(path, ec)) {
    std::ifstream existing(path, std::ios::binary);
    char header[16] = {};
    existing.read(header, sizeof(header));
    ThrowUnless(std::string(header, existing.gcount()) !=
                    std::string("SQLite format 3\0", 16),
                StrCat("refusing to overwrite the database ", path,
                       " with an output"));
  }
}

void CheckOutputFile(const std::string& path,
                     const std::vector<std::string>& inputs) {
  CheckReplaceableFile(path);
  const fs::path normal = NormalizePath(path);
  const std::string name = normal.filename().string();
  std::error_code ec;
  const bool model_file_name =
      name == "cameras.bin" || name == "images.bin" ||
      name == "points3D.bin" || name == "cameras.txt" ||
      name == "images.txt" || name == "points3D.txt";
  const fs::path folder = normal.parent_path();
  ThrowUnless(!model_file_name ||
                  !(fs::is_regular_file(folder / "cameras.bin", ec) ||
                    fs::is_regular_file(folder / "cameras.txt", ec)),
              StrCat("refusing to write an output over the file ", name,
                     " of the COLMAP model in ", folder.string()));
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    const bool same_file = fs::exists(path, ec) && fs::exists(input, ec) &&
                           fs::equivalent(path, input, ec);
    ThrowUnless(!same_file && !IsSameOrInside(path, input),
                fs::is_directory(input, ec)
                    ? StrCat("refusing to write an output inside the input "
                             "folder ",
                             input, ": ", path)
                    : StrCat("refusing to overwrite the input ", input,
                             " with an output"));
  }
}

void WriteFileAtomically(const std::string& path, const std::string& contents) {
  CheckReplaceableFile(path);
  std::error_code ec;
  const std::string temp = path + ".tmp-" + RandomSuffix();
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    ThrowUnless(out.good(), StrCat("cannot write ", temp));
    out << contents;
    if (!out.good()) {
      out.close();
      fs::remove(temp, ec);
      throw Error(StrCat("cannot write ", temp));
    }
  }
  fs::rename(temp, path, ec);
  if (ec) {
    const std::string message = ec.message();
    fs::remove(temp, ec);
    throw Error(StrCat("cannot rename ", temp, " to ", path, ": ", message));
  }
}

std::string TailOfFile(const std::string& path, size_t max_lines) {
  std::ifstream in(path);
  std::deque<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    lines.push_back(line);
    if (lines.size() > max_lines) lines.pop_front();
  }
  std::string out;
  for (const std::string& l : lines) {
    if (!out.empty()) out += " | ";
    out += l;
  }
  return out;
}

std::string ReadTextFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  ThrowUnless(in.good(), StrCat("cannot read ", path));
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

}  // namespace hisfm
