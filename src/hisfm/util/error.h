// Errors reported to the user as one line, and checks of preconditions.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

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

/// An option out of range. Names the option (the field of its options
/// struct, or the command-line flag that sets it: WithName), the value it got
/// and what it must be: "invalid option top_k = 0: must be >= 1".
class OptionError : public Error {
 public:
  /// `field` is the option's address: the command line maps it to its flag.
  OptionError(const void* field, const std::string& name,
              const std::string& value, const std::string& requirement)
      : Error(StrCat("invalid option ", name, " = ", value, ": must be ",
                     requirement)),
        field_(field),
        name_(name),
        value_(value),
        requirement_(requirement) {}

  /// Address of the failing option (a field of an options struct).
  const void* field() const { return field_; }
  /// The option's name in the message (field or flag).
  const std::string& name() const { return name_; }
  /// The value it got, as text.
  const std::string& value() const { return value_; }
  /// What it must be (">= 1", "in [0, 1]", ...).
  const std::string& requirement() const { return requirement_; }
  /// The same error naming the option `name` (e.g. its flag).
  OptionError WithName(const std::string& name) const {
    return OptionError(field_, name, value_, requirement_);
  }

 private:
  const void* field_;
  std::string name_;
  std::string value_;
  std::string requirement_;
};

/// An option's value as text for OptionError: numbers as streamed, bools
/// as true/false, strings quoted, lists in brackets.
template <typename T>
std::string OptionValueText(const T& value) {
  return StrCat(value);
}
inline std::string OptionValueText(bool value) {
  return value ? "true" : "false";
}
inline std::string OptionValueText(const std::string& value) {
  return StrCat('"', value, '"');
}
template <typename T>
std::string OptionValueText(const std::vector<T>& values) {
  std::string out = "[";
  for (size_t i = 0; i < values.size(); ++i) {
    out += (i > 0 ? ", " : "") + OptionValueText(values[i]);
  }
  return out + "]";
}

}  // namespace hisfm

/// Checks option `field` of an options struct (inside its Check()): unless
/// `cond` holds, throws hisfm::OptionError naming the field, its value and
/// `requirement` ("invalid option top_k = 0: must be >= 1").
#define HISFM_CHECK_OPTION(field, cond, requirement)                     \
  do {                                                                   \
    if (!(cond)) {                                                       \
      throw ::hisfm::OptionError(&(field), #field,                       \
                                 ::hisfm::OptionValueText(field),        \
                                 (requirement));                         \
    }                                                                    \
  } while (false)
