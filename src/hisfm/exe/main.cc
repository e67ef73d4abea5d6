// Entry point of the `hisfm` command: dispatches to the registered
// sub-commands and turns errors into one line and a non-zero exit.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "hisfm/exe/command.h"
#include "hisfm/util/error.h"

namespace hisfm {

std::map<std::string, CommandInfo>& CommandRegistry() {
  static std::map<std::string, CommandInfo> registry;
  return registry;
}

namespace {

void PrintUsage() {
  std::printf(
      "HiSfM: hierarchical, disambiguating structure-from-motion on COLMAP "
      "databases.\n\nUsage: hisfm <command> [options]\n       hisfm <command> "
      "-h\n\nCommands:\n");
  for (const auto& [name, info] : CommandRegistry()) {
    std::printf("  %-16s %s\n", name.c_str(), info.description.c_str());
  }
}

}  // namespace
}  // namespace hisfm

int main(int argc, char** argv) {
  using namespace hisfm;
  if (argc < 2 || std::string(argv[1]) == "-h" ||
      std::string(argv[1]) == "--help" || std::string(argv[1]) == "help") {
    PrintUsage();
    return argc < 2 ? 1 : 0;
  }
  const std::string name = argv[1];
  auto it = CommandRegistry().find(name);
  if (it == CommandRegistry().end()) {
    std::fprintf(stderr, "error: unknown command '%s' (see hisfm -h)\n",
                 name.c_str());
    return 2;
  }
  std::string program = std::string("hisfm ") + name;
  std::vector<char*> args;
  args.push_back(program.data());
  for (int i = 2; i < argc; ++i) args.push_back(argv[i]);
  try {
    return it->second.run(static_cast<int>(args.size()), args.data());
  } catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
