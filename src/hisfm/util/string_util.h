// Small string helpers.
#pragma once

#include <cmath>
#include <cstddef>
#include <sstream>
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

/// `value` with `digits` fixed decimals; "-" for NaN or infinity.
inline std::string FormatFixed(double value, int digits) {
  if (!std::isfinite(value)) return "-";
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

/// `value` as a stream prints it with 10 significant digits ("1e-06",
/// "1.25"): for passing numbers to other programs' command lines.
inline std::string FormatScientific(double value) {
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

/// Number of non-overlapping occurrences of `what` in `text`.
inline size_t CountOccurrences(const std::string& text,
                               const std::string& what) {
  size_t n = 0;
  for (size_t pos = text.find(what); pos != std::string::npos;
       pos = text.find(what, pos + what.size())) {
    ++n;
  }
  return n;
}

}  // namespace hisfm
