// Entry point of the `hisfm` command: dispatches to the registered
// sub-commands and turns errors into one line and a non-zero exit.
#include <csignal>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "hisfm/exe/command.h"
#include "hisfm/util/error.h"
#include "hisfm/util/interrupt.h"

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
      "-h (or hisfm help <command>)\n       hisfm --version\n\nCommands:\n");
  for (const auto& [name, info] : CommandRegistry()) {
    std::printf("  %-16s %s\n", name.c_str(), info.description.c_str());
  }
}

}  // namespace
}  // namespace hisfm

int main(int argc, char** argv) {
  using namespace hisfm;
  const std::string first = argc < 2 ? "" : argv[1];
  if (first == "--version" || first == "version") {
    std::printf("hisfm %s\n", HISFM_VERSION);
    return 0;
  }
  // `hisfm help mapper` is `hisfm mapper -h`.
  const bool help_on_command = first == "help" && argc == 3;
  if (!help_on_command &&
      (argc < 2 || first == "-h" || first == "--help" || first == "help")) {
    PrintUsage();
    return argc < 2 ? 1 : 0;
  }
  const std::string name = help_on_command ? argv[2] : first;
  auto it = CommandRegistry().find(name);
  if (it == CommandRegistry().end()) {
    std::fprintf(stderr, "error: unknown command '%s' (see hisfm -h)\n",
                 name.c_str());
    return 2;
  }
  std::string program = std::string("hisfm ") + name;
  std::vector<char*> args;
  args.push_back(program.data());
  std::string help_flag = "-h";
  if (help_on_command) {
    args.push_back(help_flag.data());
  } else {
    for (int i = 2; i < argc; ++i) args.push_back(argv[i]);
  }
  try {
    return it->second.run(static_cast<int>(args.size()), args.data());
  } catch (const Interrupted& e) {
    // Cleaned up: now end by the signal itself, so that a calling shell
    // script stops as it would for any other interrupted program.
    std::fprintf(stderr, "error: %s\n", e.what());
    std::fflush(stderr);
    signal(e.signal(), SIG_DFL);
    raise(e.signal());
    return 128 + e.signal();
  } catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
