#include "hisfm/util/child_process.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

// Runs `sh -c script` with its output in `log`; the exit code.
int RunScript(const std::string& script, const std::string& log,
              int* start_error) {
  const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  EXPECT_GE(fd, 0);
  const int code = RunChildProcess({"sh", "-c", script}, CurrentEnvironment(),
                                   fd, start_error);
  close(fd);
  return code;
}

bool Alive(pid_t pid) { return kill(pid, 0) == 0 || errno == EPERM; }

// Waits up to `seconds` for `pid` to be gone (a zombie counts as gone:
// only its parent can reap it).
bool GoneWithin(pid_t pid, double seconds) {
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(stat, line)) return true;
    // State is the field after the parenthesised name.
    const size_t close = line.rfind(')');
    if (close != std::string::npos && close + 2 < line.size() &&
        line[close + 2] == 'Z') {
      return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return !Alive(pid);
}

TEST(ChildProcess, ExitCodesOutputAndEnvironment) {
  TempDir tmp;
  int error = 0;
  EXPECT_EQ(RunScript("echo out; echo err >&2; exit 3", tmp / "log", &error),
            3);
  EXPECT_EQ(error, 0);
  EXPECT_EQ(ReadTextFile(tmp / "log"), "out\nerr\n");
  EXPECT_EQ(RunScript("read x || echo no-input", tmp / "log", &error), 0);
  EXPECT_EQ(ReadTextFile(tmp / "log"), "no-input\n") << "stdin is /dev/null";
  EXPECT_EQ(RunScript("kill -9 $$", tmp / "log", &error), 128 + 9);
  const int fd = open((tmp / "env").c_str(), O_WRONLY | O_CREAT, 0644);
  EXPECT_EQ(RunChildProcess({"sh", "-c", "echo $HISFM_TEST_VALUE"},
                            {"HISFM_TEST_VALUE=42"}, fd, &error),
            0);
  close(fd);
  EXPECT_EQ(ReadTextFile(tmp / "env"), "42\n");
}

TEST(ChildProcess, MissingProgramsAreReported) {
  TempDir tmp;
  int error = 0;
  EXPECT_EQ(RunChildProcess({"no-such-program-hisfm"}, CurrentEnvironment(), 1,
                            &error),
            -1);
  EXPECT_EQ(error, ENOENT);
  std::ofstream(tmp / "not-executable") << "#!/bin/sh\n";
  EXPECT_EQ(RunChildProcess({tmp / "not-executable"}, CurrentEnvironment(), 1,
                            &error),
            -1);
  EXPECT_EQ(error, EACCES);
}

// The child runs in its own process group: what it leaves behind is killed
// when it ends.
TEST(ChildProcess, LeavesNothingRunning) {
  TempDir tmp;
  int error = 0;
  ASSERT_EQ(
      RunScript("sleep 300 & echo $! > " + (tmp / "pid"), tmp / "log", &error),
      0);
  const pid_t grandchild = std::stoi(ReadTextFile(tmp / "pid"));
  EXPECT_TRUE(GoneWithin(grandchild, 3.0));
}

// kill -9 of the process that started the child: the child and what it
// started end within 3 s.
TEST(ChildProcess, DiesWithItsParentEvenByKill9) {
  TempDir tmp;
  const std::string pids = tmp / "pids";
  const pid_t parent = fork();
  ASSERT_GE(parent, 0);
  if (parent == 0) {
    int error = 0;
    const std::string script = "sleep 300 & echo $$ $! > " + pids +
                               ".tmp; mv " + pids + ".tmp " + pids + "; wait";
    RunChildProcess({"sh", "-c", script}, CurrentEnvironment(), 2, &error);
    _exit(0);
  }
  for (int i = 0; i < 500 && !std::ifstream(pids).good(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::istringstream in(ReadTextFile(pids));
  pid_t child = 0, grandchild = 0;
  in >> child >> grandchild;
  ASSERT_GT(child, 0);
  ASSERT_GT(grandchild, 0);
  EXPECT_TRUE(Alive(child));
  ASSERT_EQ(kill(parent, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(waitpid(parent, &status, 0), parent);
  EXPECT_TRUE(GoneWithin(child, 3.0));
  EXPECT_TRUE(GoneWithin(grandchild, 3.0));
}

}  // namespace
}  // namespace hisfm
