// libFuzzer target: a text COLMAP model (cameras.txt, images.txt,
// points3D.txt packed as in fuzz_input.h's SplitFramed), read, validated and
// written back (fuzz_checks.h).
#include <string>

#include "fuzz_checks.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hisfm::fuzz;
  static const std::string folder = ScratchSubfolder("text");
  std::string files[3];
  SplitFramed(data, size, 3, files);
  const char* names[] = {"cameras.txt", "images.txt", "points3D.txt"};
  for (int k = 0; k < 3; ++k) {
    WriteBytes(folder + "/" + names[k],
               reinterpret_cast<const uint8_t*>(files[k].data()),
               files[k].size());
  }
  CheckModel(folder, nullptr);
  return 0;
}
