#include "hisfm/cli/keyword_options.h"

#include <algorithm>
#include <set>

namespace hisfm {
namespace {

// The flags of `app` that keywords may set.
std::vector<const CLI::Option*> KeywordFlags(const CLI::App& app) {
  std::vector<const CLI::Option*> out;
  for (const CLI::Option* option : app.get_options()) {
    if (option == app.get_help_ptr() || option == app.get_help_all_ptr() ||
        option == app.get_config_ptr() || option->get_lnames().empty()) {
      continue;
    }
    out.push_back(option);
  }
  return out;
}

}  // namespace

std::string KeywordOfFlag(const std::string& flag) {
  size_t start = flag.find_first_not_of('-');
  if (start == std::string::npos) return "";
  const size_t dot = flag.rfind('.');
  if (dot != std::string::npos && dot >= start) start = dot + 1;
  return flag.substr(start);
}

std::vector<std::string> KeywordsOf(const CLI::App& app) {
  std::vector<std::string> out;
  for (const CLI::Option* option : KeywordFlags(app)) {
    out.push_back(KeywordOfFlag(option->get_name()));
  }
  return out;
}

void ParseKeywords(
    CLI::App& app,
    const std::vector<std::pair<std::string, std::string>>& keywords) {
  std::vector<std::string> args;
  std::set<std::string> seen;
  const std::vector<const CLI::Option*> flags = KeywordFlags(app);
  for (const auto& [keyword, value] : keywords) {
    // (clang 14 cannot capture a structured binding.)
    const std::string& name = keyword;
    const auto flag = std::find_if(
        flags.begin(), flags.end(), [&name](const CLI::Option* option) {
          return KeywordOfFlag(option->get_name()) == name;
        });
    if (flag == flags.end()) {
      throw UnknownKeyword(StrCat("unknown option '", keyword, "'"));
    }
    if (!seen.insert(keyword).second) {
      throw UnknownKeyword(StrCat("option '", keyword, "' given twice"));
    }
    args.push_back((*flag)->get_name());
    args.push_back(value);
  }
  // CLI11 takes the arguments last first.
  std::reverse(args.begin(), args.end());
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    std::string message = e.what();
    std::replace(message.begin(), message.end(), '\n', ' ');
    throw BadKeywordValue(message);
  }
}

}  // namespace hisfm
