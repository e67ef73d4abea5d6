// Options given by keyword (the Python module's `top_k=1`), parsed through
// the command line's own flags, so that names, conversions, defaults and
// checks are those of `hisfm <command>`.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <utility>
#include <vector>

#include "hisfm/util/error.h"

namespace hisfm {

/// A keyword no flag of the command has (Python raises TypeError for it).
class UnknownKeyword : public Error {
 public:
  explicit UnknownKeyword(const std::string& message) : Error(message) {}
};

/// A value its flag cannot take (Python raises ValueError for it).
class BadKeywordValue : public Error {
 public:
  explicit BadKeywordValue(const std::string& message) : Error(message) {}
};

/// The keyword of a flag: its name without the leading dashes and without a
/// `Section.` prefix ("--HiSfM.top_k" -> "top_k", "--log_level" ->
/// "log_level").
std::string KeywordOfFlag(const std::string& flag);

/// The keywords of the flags of `app` (not its help or config options), in
/// the order they were added.
std::vector<std::string> KeywordsOf(const CLI::App& app);

/// Parses `keywords` (keyword, value as text) as the command line
/// `--FLAG value ...` of `app`, FLAG being the flag whose KeywordOfFlag is
/// the keyword. Throws UnknownKeyword naming a keyword without a flag (or
/// one given twice), BadKeywordValue with CLI11's one-line message when a
/// value does not convert or a required flag is missing.
void ParseKeywords(CLI::App& app,
                   const std::vector<std::pair<std::string, std::string>>&
                       keywords);

}  // namespace hisfm
