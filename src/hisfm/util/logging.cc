#include "hisfm/util/logging.h"

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
    std::fprintf(stderr, "\r\033[K%s: %zu/%zu, %.0f s left", what_.c_str(),
                 done_, total_, eta);
    std::fflush(stderr);
    g_progress_line_active = true;
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
  if (tty_ && g_progress_line_active.exchange(false)) {
    std::fprintf(stderr, "\r\033[K");
  }
  Logger().info("{}: {}/{} done in {:.1f} s", what_, total_, total_, elapsed);
}

}  // namespace hisfm
