#include "hisfm/util/file_util.h"

#include <unistd.h>

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

void WriteFileAtomically(const std::string& path, const std::string& contents) {
  const std::string temp = path + ".tmp-" + RandomSuffix();
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    ThrowUnless(out.good(), StrCat("cannot write ", temp));
    out << contents;
    ThrowUnless(out.good(), StrCat("cannot write ", temp));
  }
  std::error_code ec;
  fs::rename(temp, path, ec);
  ThrowUnless(!ec, StrCat("cannot rename ", temp, " to ", path, ": ",
                          ec.message()));
}

std::string ReadTextFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  ThrowUnless(in.good(), StrCat("cannot read ", path));
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

}  // namespace hisfm
