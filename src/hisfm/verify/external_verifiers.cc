#include "hisfm/verify/external_verifiers.h"

#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hisfm/util/error.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/file_util.h"

namespace hisfm {
namespace {

std::pair<std::string, std::string> Key(const std::string& a,
                                        const std::string& b) {
  return a < b ? std::make_pair(a, b) : std::make_pair(b, a);
}

const std::string& NameOf(const VerifierContext& context, ImageId id) {
  auto it = context.image_names.find(id);
  ThrowUnless(it != context.image_names.end(),
              StrCat("verifier: unknown image id ", id));
  return it->second;
}

std::vector<double> LookUp(
    const std::map<std::pair<std::string, std::string>, double>& scores,
    const std::vector<ImagePair>& pairs, const VerifierContext& context,
    const std::string& source) {
  std::vector<double> out;
  for (const ImagePair& p : pairs) {
    const std::string& a = NameOf(context, p.image_id1);
    const std::string& b = NameOf(context, p.image_id2);
    auto it = scores.find(Key(a, b));
    ThrowUnless(it != scores.end(),
                StrCat(source, " has no score for the pair ", a, " ", b));
    out.push_back(it->second);
  }
  return out;
}

}  // namespace

std::map<std::pair<std::string, std::string>, double> ParseScoreLines(
    const std::string& text, const std::string& source) {
  std::map<std::pair<std::string, std::string>, double> out;
  std::istringstream in(text);
  std::string line;
  size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string a, b, p, extra;
    if (!(fields >> a)) continue;
    char* end = nullptr;
    double value = NAN;
    if (fields >> b >> p) value = std::strtod(p.c_str(), &end);
    const bool ok = !p.empty() && end && *end == '\0' && !(fields >> extra) &&
                    std::isfinite(value) && value >= 0.0 && value <= 1.0;
    ThrowUnless(ok, StrCat(source, " line ", number,
                           ": expected 'name1 name2 probability' with a "
                           "probability in [0, 1]"));
    out[Key(a, b)] = value;
  }
  return out;
}

ScoresFileVerifier::ScoresFileVerifier(const std::string& path,
                                       const VerifierContext& context)
    : path_(path), context_(context) {
  CheckFileReadable(path, "verifier scores file");
  scores_ = ParseScoreLines(ReadTextFile(path), "verifier scores file " + path);
}

std::vector<double> ScoresFileVerifier::Score(
    const std::vector<ImagePair>& pairs) {
  return LookUp(scores_, pairs, context_, "verifier scores file " + path_);
}

CommandVerifier::CommandVerifier(std::string command, size_t batch_size,
                                 const VerifierContext& context)
    : command_(std::move(command)),
      batch_size_(std::max<size_t>(1, batch_size)),
      context_(context) {
  ThrowUnless(!command_.empty(), "verifier command is empty");
}

std::vector<double> CommandVerifier::Score(
    const std::vector<ImagePair>& pairs) {
  std::vector<double> scores;
  scores.reserve(pairs.size());
  for (size_t begin = 0; begin < pairs.size(); begin += batch_size_) {
    const size_t end = std::min(pairs.size(), begin + batch_size_);
    const std::vector<double> batch = ScoreBatch(
        std::vector<ImagePair>(pairs.begin() + begin, pairs.begin() + end));
    scores.insert(scores.end(), batch.begin(), batch.end());
  }
  return scores;
}

std::vector<double> CommandVerifier::ScoreBatch(
    const std::vector<ImagePair>& pairs) {
  namespace fs = std::filesystem;
  char dir_template[] = "/tmp/hisfm-verifier-XXXXXX";
  ThrowUnless(mkdtemp(dir_template) != nullptr,
              "cannot create a temporary folder in /tmp");
  const std::string dir = dir_template;
  const std::string input = dir + "/pairs.txt";
  const std::string output = dir + "/scores.txt";
  const std::string log = dir + "/log.txt";
  struct Cleanup {
    std::string dir;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  } cleanup{dir};
  {
    std::ofstream out(input);
    for (const ImagePair& p : pairs) {
      out << NameOf(context_, p.image_id1) << ' '
          << NameOf(context_, p.image_id2) << '\n';
    }
  }
  const std::string full = "HISFM_IMAGE_PATH=" +
                           ShellQuote(context_.image_path) + " " + command_ +
                           " " + ShellQuote(input) + " " + ShellQuote(output) +
                           " > " + ShellQuote(log) + " 2>&1";
  const int status = std::system(full.c_str());
  ThrowIfInterrupted(status);
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  if (code != 0) {
    const std::string last = TailOfFile(log, 1);
    throw Error(StrCat("verifier command failed (exit ", code, "): ",
                       command_, last.empty() ? "" : " -- " + last));
  }
  ThrowUnless(fs::exists(output),
              StrCat("verifier command wrote no scores: ", command_));
  return LookUp(ParseScoreLines(ReadTextFile(output),
                                "output of verifier command " + command_),
                pairs, context_, "output of verifier command " + command_);
}

}  // namespace hisfm
