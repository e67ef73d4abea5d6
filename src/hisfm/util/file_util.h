// File-system helpers: paths, existence checks, and atomic output folders.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace hisfm {

/// Throws Error unless `path` is an existing regular, readable file.
void CheckFileReadable(const std::string& path, const std::string& what);

/// Throws Error unless `path` is an existing directory.
void CheckDirectoryExists(const std::string& path, const std::string& what);

/// True if `path` does not exist or is an empty directory.
bool IsMissingOrEmptyDirectory(const std::string& path);

/// `path` made absolute and lexically normal, with the symbolic links of its
/// existing part resolved and without a trailing separator ("out/" and
/// "./out" give the same result).
std::string NormalizePath(const std::string& path);

/// True if `path` is `folder` or lies below it (both normalized first).
bool IsSameOrInside(const std::string& path, const std::string& folder);

/// Empties (or creates) a folder for a run's intermediate files and marks it
/// as such. A folder that is not empty is only emptied if an earlier call
/// marked it, or if it holds `legacy_file` (set by callers whose earlier
/// versions wrote that file first into every work folder, before the mark
/// existed); anything else (a user's folder, a file) is refused with an
/// Error, so that a mistyped path never deletes data.
void PrepareWorkDirectory(const std::string& path,
                          const std::string& legacy_file = "");

/// A folder that is filled under a temporary name next to its final path and
/// renamed into place by Commit(), so that an interrupted run never leaves a
/// half-written result at `final_path`. Without Commit() the temporary folder
/// is removed by the destructor.
class AtomicDirectory {
 public:
  /// `final_path` must not exist, or be an empty directory (then replaced).
  explicit AtomicDirectory(std::string final_path);
  ~AtomicDirectory();
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;

  /// The temporary folder to write into.
  const std::string& path() const { return temp_path_; }
  /// Renames the temporary folder to the final path.
  void Commit();

 private:
  std::string final_path_;
  std::string temp_path_;
  bool committed_ = false;
};

/// Throws Error if `path` is a folder or a SQLite database: no file output
/// of HiSfM replaces one, so such a path is a mistake (an input given as the
/// output). WriteFileAtomically checks it.
void CheckReplaceableFile(const std::string& path);

/// Throws Error unless a command may write its output file at `path`:
/// CheckReplaceableFile, and `path` is neither a file of a COLMAP model
/// (cameras, images or points3D .bin or .txt in a folder holding
/// cameras.bin or cameras.txt) nor one of `inputs` (the command's input
/// files, also through another name or a hard link) nor inside one of them
/// (its input folders, e.g. model folders). Commands call it before their
/// work; an existing file that passes is an earlier output, which
/// WriteFileAtomically replaces in one step.
void CheckOutputFile(const std::string& path,
                     const std::vector<std::string>& inputs = {});

/// Writes `contents` to `path` through a temporary file and a rename, after
/// CheckReplaceableFile: readers of `path` see the old file or the new one,
/// never a part.
void WriteFileAtomically(const std::string& path, const std::string& contents);

/// Last `max_lines` non-empty lines of a text file, joined by " | " (empty if
/// it cannot be read): the end of a log, for an error message.
std::string TailOfFile(const std::string& path, size_t max_lines);

/// Reads a whole text file; throws Error if it cannot be read.
std::string ReadTextFile(const std::string& path);

}  // namespace hisfm
