// Errors reported to the user as one line, and checks of preconditions.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace hisfm {

/// An error caused by the input or the environment (bad database, missing
/// folder, failing colmap call). Its message is one line meant for the user;
/// the `hisfm` command prints it and exits with a non-zero status.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// Throws Error(message) unless condition holds.
inline void ThrowUnless(bool condition, const std::string& message) {
  if (!condition) throw Error(message);
}

/// Builds a message from streamable parts: StrCat("n=", 3).
template <typename... Args>
std::string StrCat(const Args&... args) {
  std::ostringstream out;
  (out << ... << args);
  return out.str();
}

}  // namespace hisfm

/// Checks an option or invariant; throws hisfm::Error naming the condition.
#define HISFM_CHECK_OPTION(cond)                                          \
  ::hisfm::ThrowUnless((cond), std::string("invalid option: ") + #cond)
