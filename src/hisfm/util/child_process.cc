#include "hisfm/util/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include "hisfm/util/interrupt.h"

extern char** environ;

namespace hisfm {
namespace {

// `name` if it has a slash, else the first executable file of that name in
// the folders of PATH; "" if there is none.
std::string FindExecutable(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const char* env = std::getenv("PATH");
  const std::string path = env ? env : "/usr/local/bin:/usr/bin:/bin";
  size_t begin = 0;
  while (begin <= path.size()) {
    size_t end = path.find(':', begin);
    if (end == std::string::npos) end = path.size();
    const std::string dir = end > begin ? path.substr(begin, end - begin) : ".";
    const std::string candidate = dir + "/" + name;
    struct stat st;
    if (stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        access(candidate.c_str(), X_OK) == 0) {
      return candidate;
    }
    begin = end + 1;
  }
  return "";
}

// Waits for `pid` to end and reaps it; its wait status.
int Reap(pid_t pid) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

// The watchdog (a forked copy of this process: async-signal-safe calls
// only): waits until nothing holds the write end of the pipe `watch_fd`
// reads, then kills the process group `group` and ends.
[[noreturn]] void RunWatchdog(int watch_fd, pid_t group) {
  // Its command line is hisfm's; its name (ps -o comm) says what it is.
  prctl(PR_SET_NAME, "hisfm-watchdog");
  struct sigaction ignore = {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  for (const int signal : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) {
    sigaction(signal, &ignore, nullptr);
  }
  sigset_t none;
  sigemptyset(&none);
  sigprocmask(SIG_SETMASK, &none, nullptr);
  // Nothing of hisfm's kept open: standard input is the pipe, output goes
  // nowhere, every other descriptor is closed.
  dup2(watch_fd, STDIN_FILENO);
  const int null_fd = open("/dev/null", O_WRONLY);
  if (null_fd >= 0) {
    dup2(null_fd, STDOUT_FILENO);
    dup2(null_fd, STDERR_FILENO);
  }
  if (close_range(3, ~0U, 0) != 0) {
    for (int fd = 3; fd < 4096; ++fd) close(fd);
  }
  char byte;
  for (;;) {
    const ssize_t n = read(STDIN_FILENO, &byte, 1);
    if (n == 0 || (n < 0 && errno != EINTR)) break;
  }
  kill(-group, SIGKILL);
  _exit(0);
}

}  // namespace

std::vector<std::string> CurrentEnvironment() {
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) env.emplace_back(*e);
  return env;
}

int RunChildProcess(const std::vector<std::string>& argv,
                    const std::vector<std::string>& env, int output_fd,
                    int* start_error) {
  *start_error = 0;
  const std::string path = argv.empty() ? "" : FindExecutable(argv[0]);
  if (path.empty()) {
    *start_error = ENOENT;
    return -1;
  }
  // Everything the forked child needs is prepared here: it must not
  // allocate (another thread may hold the allocator's lock).
  std::vector<char*> cargs, cenv;
  for (const std::string& a : argv)
    cargs.push_back(const_cast<char*>(a.c_str()));
  cargs.push_back(nullptr);
  for (const std::string& e : env) cenv.push_back(const_cast<char*>(e.c_str()));
  cenv.push_back(nullptr);

  // exec_pipe: the child reports a failed execve; watch_pipe: closes when
  // this process ends, for the watchdog.
  int exec_pipe[2], watch_pipe[2];
  if (pipe2(exec_pipe, O_CLOEXEC) != 0) {
    *start_error = errno;
    return -1;
  }
  if (pipe2(watch_pipe, O_CLOEXEC) != 0) {
    *start_error = errno;
    close(exec_pipe[0]);
    close(exec_pipe[1]);
    return -1;
  }
  const pid_t parent = getpid();
  // No signal handler of hisfm may run in a forked copy.
  sigset_t all, old_mask;
  sigfillset(&all);
  pthread_sigmask(SIG_SETMASK, &all, &old_mask);
  const pid_t pid = fork();
  if (pid == 0) {
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);  // Ended before prctl.
    struct sigaction default_action = {};
    default_action.sa_handler = SIG_DFL;
    sigemptyset(&default_action.sa_mask);
    for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction current;
      sigaction(signal, nullptr, &current);
      // Ignored signals stay ignored (nohup).
      if (current.sa_handler != SIG_IGN) {
        sigaction(signal, &default_action, nullptr);
      }
    }
    pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
    const int null_fd = open("/dev/null", O_RDONLY);
    if (dup2(output_fd, STDOUT_FILENO) >= 0 &&
        dup2(output_fd, STDERR_FILENO) >= 0 && null_fd >= 0 &&
        dup2(null_fd, STDIN_FILENO) >= 0) {
      execve(path.c_str(), cargs.data(), cenv.data());
    }
    const int error = errno;
    (void)!write(exec_pipe[1], &error, sizeof(error));
    _exit(127);
  }
  const int fork_error = errno;
  pid_t watchdog = -1;
  if (pid > 0) {
    // Also here, so that the group exists before the watchdog needs it.
    setpgid(pid, pid);
    watchdog = fork();
    if (watchdog == 0) {
      close(watch_pipe[1]);
      RunWatchdog(watch_pipe[0], pid);
    }
  }
  pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
  close(exec_pipe[1]);
  close(watch_pipe[0]);
  if (pid < 0) {
    close(exec_pipe[0]);
    close(watch_pipe[1]);
    *start_error = fork_error;
    return -1;
  }
  int exec_error = 0;
  ssize_t n = 0;
  while ((n = read(exec_pipe[0], &exec_error, sizeof(exec_error))) < 0 &&
         errno == EINTR) {
  }
  close(exec_pipe[0]);
  if (n == static_cast<ssize_t>(sizeof(exec_error))) {
    Reap(pid);
    close(watch_pipe[1]);
    if (watchdog > 0) Reap(watchdog);
    *start_error = exec_error;
    return -1;
  }
  AddInterruptibleChild(-pid);
  // Waits without reaping: until the watchdog has killed what is left of
  // the group, its id stays the child's.
  siginfo_t info;
  while (waitid(P_PID, pid, &info, WEXITED | WNOWAIT) < 0 && errno == EINTR) {
  }
  RemoveInterruptibleChild(-pid);
  close(watch_pipe[1]);
  if (watchdog > 0) Reap(watchdog);
  const int status = Reap(pid);
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

}  // namespace hisfm
