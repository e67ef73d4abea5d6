// What the fuzz targets check about the database and model readers
// (tests/fuzz/README.md): bad input ends in hisfm::Error or a reported
// problem, never in a crash, another exception or a huge allocation, and
// input that passes validation is safe for every reader.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace hisfm {
namespace fuzz {

/// Reports a broken invariant and aborts (libFuzzer saves the input).
[[noreturn]] void Fail(const std::string& what);

/// A folder for this process's scratch files (tmpfs if there is one),
/// removed at exit.
const std::string& ScratchFolder();

/// ScratchFolder()/name, created.
std::string ScratchSubfolder(const std::string& name);

/// Writes `size` bytes to `path`, replacing it.
void WriteBytes(const std::string& path, const uint8_t* data, size_t size);

/// Validates the database at `path` and reads it with every reader of
/// hisfm/io/database.h. Unvalidated, readers may only throw hisfm::Error;
/// validated, what they return must hold what validation promises (counts,
/// indices, finite values), and the filtered copy hisfm hands to colmap
/// must validate too. With `intact_file` (a file SQLite itself wrote) no
/// reader may throw; otherwise (mutated bytes) the SQLite file may be
/// damaged where validation does not look (b-tree order, pages it does not
/// read), and readers may throw hisfm::Error.
void CheckDatabase(const std::string& path, bool intact_file);

/// Reads the model folder `path`; if it parses, writing it back in binary
/// must give `binary_files` (cameras, images, points3D contents) when they
/// are given, it must survive a text round trip, and if it validates,
/// ReadModel must accept it.
void CheckModel(const std::string& path, const std::string* binary_files);

}  // namespace fuzz
}  // namespace hisfm
