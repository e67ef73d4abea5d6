#include "hisfm/util/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <unistd.h>

#include <cstdio>

namespace hisfm {

spdlog::logger& Logger() {
  static std::shared_ptr<spdlog::logger> logger = [] {
    auto l = spdlog::stderr_color_mt("hisfm");
    l->set_pattern("[%H:%M:%S.%e] %^%l%$ %v");
    l->set_level(spdlog::level::info);
    return l;
  }();
  return *logger;
}

void SetLogLevel(const std::string& level) {
  Logger().set_level(spdlog::level::from_str(level));
}

void LogHeading(const std::string& title) { Logger().info("==> {}", title); }

ProgressReporter::ProgressReporter(std::string what, size_t total)
    : what_(std::move(what)),
      total_(total),
      tty_(isatty(fileno(stderr)) != 0),
      start_(std::chrono::steady_clock::now()),
      last_print_(start_) {}

void ProgressReporter::Update(size_t done) {
  done_ = done;
  const auto now = std::chrono::steady_clock::now();
  const double since_print =
      std::chrono::duration<double>(now - last_print_).count();
  if (done_ >= total_ || since_print < (tty_ ? 0.2 : 5.0)) return;
  last_print_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double eta =
      done_ > 0 ? elapsed * (static_cast<double>(total_) - done_) / done_ : 0.0;
  if (tty_) {
    std::fprintf(stderr, "\r%s: %zu/%zu, %.0f s left   ", what_.c_str(),
                 done_, total_, eta);
    std::fflush(stderr);
  } else {
    Logger().info("{}: {}/{}, {:.0f} s left", what_, done_, total_, eta);
  }
}

void ProgressReporter::Finish() {
  if (finished_) return;
  finished_ = true;
  const double elapsed = std::chrono::duration<double>(
                             std::chrono::steady_clock::now() - start_)
                             .count();
  if (tty_) std::fprintf(stderr, "\r\033[K");
  Logger().info("{}: {}/{} done in {:.1f} s", what_, total_, total_, elapsed);
}

}  // namespace hisfm
