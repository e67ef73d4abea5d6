// Small string helpers.
#pragma once

#include <string>

namespace hisfm {

/// Quotes a string for /bin/sh: 'it'\''s'.
inline std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

}  // namespace hisfm
