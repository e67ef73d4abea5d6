#include "hisfm/util/logging.h"

#include <spdlog/fmt/fmt.h>
#include <spdlog/sinks/base_sink.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <mutex>

namespace hisfm {
namespace {

// True while a ProgressReporter owns the last terminal line.
std::atomic<bool> g_progress_line_active{false};

// Writes to stderr, first clearing an active progress line so that log
// lines never run into it.
class StderrSink : public spdlog::sinks::base_sink<std::mutex> {
 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    spdlog::memory_buf_t formatted;
    formatter_->format(msg, formatted);
    if (g_progress_line_active.exchange(false)) std::fputs("\r\033[K", stderr);
    std::fwrite(formatted.data(), 1, formatted.size(), stderr);
  }
  void flush_() override { std::fflush(stderr); }
};

}  // namespace

spdlog::logger& Logger() {
  static std::shared_ptr<spdlog::logger> logger = [] {
    auto l = std::make_shared<spdlog::logger>("hisfm",
                                              std::make_shared<StderrSink>());
    l->set_pattern("[%H:%M:%S.%e] %l %v");
    l->set_level(spdlog::level::info);
    return l;
  }();
  return *logger;
}

void SetLogLevel(const std::string& level) {
  Logger().set_level(spdlog::level::from_str(level));
}

void LogHeading(const std::string& title) { Logger().info("==> {}", title); }

ProgressReporter::ProgressReporter(std::string what, size_t total,
                                   double min_interval_seconds)
    : what_(std::move(what)),
      total_(total),
      tty_(isatty(fileno(stderr)) != 0),
      start_(std::chrono::steady_clock::now()),
      last_print_(start_) {
  min_interval_seconds_ =
      min_interval_seconds >= 0 ? min_interval_seconds : (tty_ ? 0.2 : 5.0);
}

void ProgressReporter::Update(size_t done) {
  done_ = done;
  const auto now = std::chrono::steady_clock::now();
  if (!has_first_) {
    has_first_ = true;
    first_done_ = done;
    first_time_ = now;
  }
  const double since_print =
      std::chrono::duration<double>(now - last_print_).count();
  if (since_print < min_interval_seconds_) return;
  last_print_ = now;
  std::string status;
  if (done_ >= total_) {
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    status = fmt::format("{}/{}, finishing ({:.0f} s so far)", total_, total_,
                         elapsed);
  } else if (done_ > first_done_) {
    const double rate_seconds =
        std::chrono::duration<double>(now - first_time_).count() /
        static_cast<double>(done_ - first_done_);
    status = fmt::format("{}/{}, {:.0f} s left", done_, total_,
                         rate_seconds * static_cast<double>(total_ - done_));
  } else {
    status = fmt::format("{}/{}", done_, total_);
  }
  if (tty_) {
    std::fprintf(stderr, "\r\033[K%s: %s", what_.c_str(), status.c_str());
    std::fflush(stderr);
    g_progress_line_active = true;
  } else {
    Logger().info("{}: {}", what_, status);
  }
}

void ProgressReporter::Finish() {
  if (finished_) return;
  finished_ = true;
  const double elapsed = std::chrono::duration<double>(
                             std::chrono::steady_clock::now() - start_)
                             .count();
  if (tty_ && g_progress_line_active.exchange(false)) {
    std::fprintf(stderr, "\r\033[K");
  }
  Logger().info("{}: {}/{} done in {:.1f} s", what_, total_, total_, elapsed);
}

}  // namespace hisfm
