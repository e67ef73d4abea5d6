// libFuzzer target: any bytes as a COLMAP database file (mutations of small
// valid databases reach SQLite's page and record formats), validated and
// read (fuzz_checks.h).
#include <string>

#include "fuzz_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hisfm::fuzz;
  const std::string path = ScratchFolder() + "/file.db";
  WriteBytes(path, data, size);
  CheckDatabase(path, /*intact_file=*/false);
  return 0;
}
