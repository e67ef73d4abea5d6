// Wall-clock timer for stage times.
#pragma once

#include <chrono>

namespace hisfm {

/// Measures wall time since construction or the last Restart().
class Timer {
 public:
  Timer() : start_(std::chrono::steady_clock::now()) {}
  /// Restarts the measurement.
  void Restart() { start_ = std::chrono::steady_clock::now(); }
  /// Seconds elapsed.
  double ElapsedSeconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                         start_)
        .count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace hisfm
