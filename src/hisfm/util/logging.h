// The one logger of HiSfM (spdlog), stage headings and progress lines.
#pragma once

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstddef>
#include <string>

namespace hisfm {

/// The project-wide logger ("hisfm"), writing to stderr.
spdlog::logger& Logger();

/// Sets the level by name: trace, debug, info, warn, error, off.
void SetLogLevel(const std::string& level);

/// Logs a stage heading, e.g. "==> Skeleton (12 communities)".
void LogHeading(const std::string& title);

/// Progress of a long stage: "what: done/total, ETA". On a terminal it
/// rewrites one line; otherwise it logs a plain line at most every few
/// seconds. Call Update() as work finishes and Finish() at the end.
class ProgressReporter {
 public:
  /// Lines are printed at most every `min_interval_seconds` (negative: 0.2 s
  /// on a terminal, 5 s otherwise).
  ProgressReporter(std::string what, size_t total,
                   double min_interval_seconds = -1);
  /// Reports that `done` of `total` items are finished. The time left is
  /// extrapolated from the rate since the first update (a resumed count, such
  /// as registrations on top of a scaffold, does not inflate the rate); once
  /// `done` reaches `total` while the work goes on (a final bundle
  /// adjustment), the line says "finishing" with the time spent.
  void Update(size_t done);
  /// Reports completion (prints the final line).
  void Finish();

 private:
  std::string what_;
  size_t total_;
  double min_interval_seconds_;
  size_t done_ = 0;
  bool has_first_ = false;
  size_t first_done_ = 0;
  std::chrono::steady_clock::time_point first_time_;
  bool tty_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_print_;
};

}  // namespace hisfm

#define HISFM_LOG_INFO(...) ::hisfm::Logger().info(__VA_ARGS__)
#define HISFM_LOG_WARN(...) ::hisfm::Logger().warn(__VA_ARGS__)
#define HISFM_LOG_DEBUG(...) ::hisfm::Logger().debug(__VA_ARGS__)
#define HISFM_LOG_ERROR(...) ::hisfm::Logger().error(__VA_ARGS__)
