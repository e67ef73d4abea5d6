// Registration of the `hisfm` sub-commands. Each command group lives in its
// own file under exe/ and registers itself with HISFM_REGISTER_COMMAND.
#pragma once

#include <functional>
#include <map>
#include <string>

namespace hisfm {

/// A sub-command: receives argv with argv[0] = "hisfm <name>", returns the
/// process exit code. It may throw hisfm::Error for a one-line user error.
using CommandFn = std::function<int(int argc, char** argv)>;

struct CommandInfo {
  std::string description;
  CommandFn run;
};

/// All registered commands by name.
std::map<std::string, CommandInfo>& CommandRegistry();

/// Registers a command at static-initialisation time.
struct CommandRegistrar {
  CommandRegistrar(const std::string& name, const std::string& description,
                   CommandFn run) {
    CommandRegistry()[name] = {description, std::move(run)};
  }
};

}  // namespace hisfm

// Use in the same namespace as `fn` (e.g. right after its definition).
#define HISFM_REGISTER_COMMAND(name, description, fn)              \
  static ::hisfm::CommandRegistrar hisfm_command_registrar_##fn( \
      name, description, fn)
