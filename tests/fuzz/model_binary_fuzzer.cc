// libFuzzer target: a binary COLMAP model (cameras.bin, images.bin,
// points3D.bin packed as in fuzz_input.h's SplitFramed), read, validated,
// written back byte for byte and through text (fuzz_checks.h).
#include <string>

#include "fuzz_checks.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hisfm::fuzz;
  static const std::string folder = ScratchSubfolder("binary");
  std::string files[3];
  SplitFramed(data, size, 3, files);
  const char* names[] = {"cameras.bin", "images.bin", "points3D.bin"};
  for (int k = 0; k < 3; ++k) {
    WriteBytes(folder + "/" + names[k],
               reinterpret_cast<const uint8_t*>(files[k].data()),
               files[k].size());
  }
  CheckModel(folder, files);
  return 0;
}
