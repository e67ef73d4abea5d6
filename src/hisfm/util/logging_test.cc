#include "hisfm/util/logging.h"

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <unistd.h>

#include <chrono>
#include <sstream>
#include <thread>

namespace hisfm {
namespace {

// Captures what the logger prints while it lives.
class CapturedLog {
 public:
  CapturedLog() : sink_(std::make_shared<spdlog::sinks::ostream_sink_mt>(out_)) {
    sink_->set_pattern("%v");
    Logger().sinks().push_back(sink_);
  }
  ~CapturedLog() { Logger().sinks().pop_back(); }
  std::string Text() {
    Logger().flush();
    return out_.str();
  }

 private:
  std::ostringstream out_;
  std::shared_ptr<spdlog::sinks::ostream_sink_mt> sink_;
};

void Pause() { std::this_thread::sleep_for(std::chrono::milliseconds(30)); }

TEST(ProgressReporter, TimeLeftUsesTheRateSinceTheFirstUpdate) {
  if (isatty(fileno(stderr))) GTEST_SKIP() << "needs a non-terminal stderr";
  CapturedLog log;
  // A resumed count: 90 of 100 were done before this run started.
  ProgressReporter progress("Attach", 100, 0.0);
  progress.Update(90);
  Pause();
  progress.Update(95);
  const std::string text = log.Text();
  // No rate is known at the first update: no promise of time left (counting
  // the 90 resumed items as done in no time would say "0 s left").
  EXPECT_NE(text.find("Attach: 90/100\n"), std::string::npos) << text;
  EXPECT_NE(text.find("Attach: 95/100, "), std::string::npos) << text;
  EXPECT_NE(text.find(" s left", text.find("Attach: 95/100")),
            std::string::npos) << text;
}

TEST(ProgressReporter, SaysFinishingOnceTheCountIsComplete) {
  if (isatty(fileno(stderr))) GTEST_SKIP() << "needs a non-terminal stderr";
  CapturedLog log;
  ProgressReporter progress("Scaffold", 4, 0.0);
  progress.Update(1);
  Pause();
  progress.Update(4);
  Pause();
  progress.Update(4);
  progress.Finish();
  const std::string text = log.Text();
  EXPECT_NE(text.find("Scaffold: 4/4, finishing ("), std::string::npos) << text;
  EXPECT_EQ(text.find("s left", text.find("Scaffold: 4/4")), std::string::npos)
      << "no time left is promised once the count is complete: " << text;
  EXPECT_NE(text.find("Scaffold: 4/4 done in"), std::string::npos) << text;
}

TEST(ProgressReporter, LinesAreRateLimited) {
  if (isatty(fileno(stderr))) GTEST_SKIP() << "needs a non-terminal stderr";
  CapturedLog log;
  ProgressReporter progress("Work", 1000, 3600.0);
  for (size_t i = 1; i < 1000; ++i) progress.Update(i);
  EXPECT_EQ(log.Text().find("Work:"), std::string::npos)
      << "nothing within the interval";
}

}  // namespace
}  // namespace hisfm
