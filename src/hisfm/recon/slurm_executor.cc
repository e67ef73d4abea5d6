#include "hisfm/recon/slurm_executor.h"

#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "hisfm/util/child_process.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"

namespace fs = std::filesystem;

namespace hisfm {

void SlurmOptions::Check() const {
  HISFM_CHECK_OPTION(sbatch_path, !sbatch_path.empty(), "non-empty");
  HISFM_CHECK_OPTION(squeue_path, !squeue_path.empty(), "non-empty");
  HISFM_CHECK_OPTION(scancel_path, !scancel_path.empty(), "non-empty");
  HISFM_CHECK_OPTION(cpus_per_task, cpus_per_task >= 1, ">= 1");
  HISFM_CHECK_OPTION(mem_mb, mem_mb >= 0, ">= 0");
  HISFM_CHECK_OPTION(time_limit_minutes, time_limit_minutes >= 0, ">= 0");
  HISFM_CHECK_OPTION(max_parallel_tasks, max_parallel_tasks >= 0, ">= 0");
  HISFM_CHECK_OPTION(max_retries, max_retries >= 0, ">= 0");
  HISFM_CHECK_OPTION(poll_seconds, poll_seconds > 0, "> 0");
}

std::string ShellQuote(const std::string& word) {
  std::string out = "'";
  for (char c : word) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

std::string FindExecutable(const std::string& name) {
  if (name.find('/') != std::string::npos) {
    return access(name.c_str(), X_OK) == 0
               ? fs::absolute(name).lexically_normal().string()
               : "";
  }
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/local/bin:/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) dir = ".";
    const std::string candidate = dir + "/" + name;
    struct stat st;
    if (stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        access(candidate.c_str(), X_OK) == 0) {
      return fs::absolute(candidate).lexically_normal().string();
    }
  }
  return "";
}

namespace {

std::string TaskFile(const std::string& dir, size_t index,
                     const std::string& suffix) {
  return StrCat(dir, "/task_", index, suffix);
}

// Runs a Slurm command; returns its exit code (-1: could not start) and its
// output (standard output and error).
int RunSlurmCommand(const std::vector<std::string>& argv,
                    std::string* output) {
  char path[] = "/tmp/hisfm-slurm-XXXXXX";
  const int fd = mkstemp(path);
  ThrowUnless(fd >= 0, "cannot create a temporary file in /tmp");
  int start_error = 0;
  const int status =
      RunChildProcess(argv, CurrentEnvironment(), fd, &start_error);
  close(fd);
  *output = ReadTextFile(path);
  unlink(path);
  if (status < 0) *output = std::strerror(start_error);
  return status;
}

std::string Trim(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) {
    s.pop_back();
  }
  size_t start = 0;
  while (start < s.size() &&
         std::isspace(static_cast<unsigned char>(s[start]))) {
    ++start;
  }
  return s.substr(start);
}

// "0-3,7,9" for sorted indices.
std::string ArraySpec(const std::vector<size_t>& indices) {
  std::string out;
  for (size_t i = 0; i < indices.size();) {
    size_t j = i;
    while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1) ++j;
    if (!out.empty()) out += ",";
    out += j == i ? StrCat(indices[i]) : StrCat(indices[i], "-", indices[j]);
    i = j + 1;
  }
  return out;
}

// Submits one array of `indices`; returns the job id.
std::string Submit(const std::vector<size_t>& indices, const std::string& dir,
                   const std::string& job_name, const SlurmOptions& options) {
  std::string spec = ArraySpec(indices);
  if (options.max_parallel_tasks > 0) {
    spec += StrCat("%", options.max_parallel_tasks);
  }
  std::vector<std::string> argv = {
      options.sbatch_path,
      "--parsable",
      "--job-name=" + job_name,
      "--array=" + spec,
      "--chdir=" + dir,
      "--output=" + dir + "/task_%a.log",
      "--open-mode=append",
      "--ntasks=1",
      StrCat("--cpus-per-task=", options.cpus_per_task),
      "--export=ALL"};
  if (!options.partition.empty()) {
    argv.push_back("--partition=" + options.partition);
  }
  if (options.mem_mb > 0) argv.push_back(StrCat("--mem=", options.mem_mb));
  if (options.time_limit_minutes > 0) {
    argv.push_back(StrCat("--time=", options.time_limit_minutes));
  }
  argv.insert(argv.end(), options.sbatch_args.begin(),
              options.sbatch_args.end());
  argv.push_back(dir + "/array.sh");
  std::string output;
  const int status = RunSlurmCommand(argv, &output);
  ThrowIfInterrupted();
  ThrowUnless(status >= 0, StrCat("cannot run ", options.sbatch_path, " (",
                                  output, "): is Slurm installed? "
                                  "(scripts/setup.sh; scripts/local_slurm.sh "
                                  "start for a one-machine cluster)"));
  output = Trim(output);
  // --parsable prints "jobid" or "jobid;cluster" on its last line.
  const std::string last = output.substr(output.rfind('\n') == std::string::npos
                                             ? 0
                                             : output.rfind('\n') + 1);
  const std::string id = last.substr(0, last.find(';'));
  const bool numeric =
      !id.empty() && id.find_first_not_of("0123456789") == std::string::npos;
  ThrowUnless(status == 0 && numeric,
              StrCat("sbatch failed (exit ", status, "): ",
                     output.empty() ? std::string("no output") : output));
  return id;
}

// True while the job has tasks in the queue. An unknown job id (purged after
// it ended) counts as finished; other squeue errors are retried for a while.
bool InQueue(const std::string& job_id, const SlurmOptions& options,
             int* squeue_failures) {
  std::string output;
  const int status = RunSlurmCommand(
      {options.squeue_path, "-h", "-j", job_id, "-o", "%i %t"}, &output);
  ThrowIfInterrupted();
  if (status == 0) {
    *squeue_failures = 0;
    return !Trim(output).empty();
  }
  if (output.find("Invalid job id") != std::string::npos) return false;
  ThrowUnless(++*squeue_failures < 60,
              StrCat("squeue keeps failing (exit ", status,
                     "): ", Trim(output)));
  return true;
}

void Cancel(const std::string& job_id, const SlurmOptions& options) {
  std::string output;
  RunSlurmCommand({options.scancel_path, job_id}, &output);
}

}  // namespace

bool SlurmTaskDone(const std::string& array_dir, size_t index,
                   const std::string& fingerprint) {
  std::ifstream in(TaskFile(array_dir, index, ".done"));
  if (!in) return false;
  std::string line;
  std::getline(in, line);
  return line == fingerprint;
}

SlurmRunResult RunSlurmTasks(const std::vector<SlurmTask>& tasks,
                             const std::string& array_dir,
                             const std::string& job_name,
                             const std::string& what,
                             const SlurmOptions& options) {
  options.Check();
  SlurmRunResult result;
  std::error_code ec;
  fs::create_directories(array_dir, ec);
  ThrowUnless(!ec, StrCat("cannot create ", array_dir, ": ", ec.message()));
  const std::string dir = fs::absolute(array_dir).lexically_normal();
  WriteFileAtomically(
      dir + "/array.sh",
      StrCat("#!/bin/bash\n"
             "# One task of a hisfm job array: runs task_<i>.sh.\n"
             "cd ",
             ShellQuote(dir),
             " || exit 1\n"
             "exec bash \"task_${SLURM_ARRAY_TASK_ID}.sh\"\n"));
  std::vector<size_t> pending;
  for (size_t i = 0; i < tasks.size(); ++i) {
    if (SlurmTaskDone(dir, i, tasks[i].fingerprint)) {
      ++result.reused;
      continue;
    }
    fs::remove(TaskFile(dir, i, ".done"), ec);
    fs::remove(TaskFile(dir, i, ".log"), ec);
    // The done mark is written only when the command succeeds, under a
    // temporary name first.
    WriteFileAtomically(
        TaskFile(dir, i, ".sh"),
        StrCat("#!/bin/bash\n# ", tasks[i].name, "\n",
               "echo \"== ", tasks[i].name,
               ": attempt on $(hostname) at $(date '+%F %T')\"\n"
               "set -o pipefail\n"
               "rm -f ",
               ShellQuote(TaskFile(dir, i, ".done")), "\n(\n",
               tasks[i].command, "\n) || exit $?\nprintf '%s\\n' ",
               ShellQuote(tasks[i].fingerprint), " > ",
               ShellQuote(TaskFile(dir, i, ".done.tmp")), " && mv ",
               ShellQuote(TaskFile(dir, i, ".done.tmp")), " ",
               ShellQuote(TaskFile(dir, i, ".done")), "\n"));
    pending.push_back(i);
  }
  if (result.reused > 0) {
    HISFM_LOG_INFO("{}: {} of {} done in an earlier run", what,
                   result.reused, tasks.size());
  }
  if (pending.empty()) return result;
  ProgressReporter progress(what, tasks.size());
  auto count_done = [&] {
    size_t n = 0;
    for (size_t i = 0; i < tasks.size(); ++i) {
      n += SlurmTaskDone(dir, i, tasks[i].fingerprint) ? 1 : 0;
    }
    return n;
  };
  for (int attempt = 0; !pending.empty(); ++attempt) {
    if (attempt > options.max_retries) {
      std::string names;
      for (size_t k = 0; k < pending.size() && k < 5; ++k) {
        const size_t i = pending[k];
        names += StrCat(k ? "; " : "", tasks[i].name, " (log ",
                        TaskFile(dir, i, ".log"), ": ",
                        TailOfFile(TaskFile(dir, i, ".log"), 2), ")");
      }
      if (pending.size() > 5) {
        names += StrCat("; and ", pending.size() - 5, " more");
      }
      throw Error(StrCat(what, ": ", pending.size(), " of ", tasks.size(),
                         " task(s) still failed after ", options.max_retries,
                         " retr", options.max_retries == 1 ? "y" : "ies",
                         ": ", names));
    }
    if (attempt > 0) {
      std::string names;
      for (size_t k = 0; k < pending.size() && k < 5; ++k) {
        names += StrCat(k ? ", " : "", tasks[pending[k]].name);
      }
      HISFM_LOG_WARN("{}: {} task(s) failed ({}{}), submitting them again "
                     "(retry {} of {})",
                     what, pending.size(), names,
                     pending.size() > 5 ? ", ..." : "", attempt,
                     options.max_retries);
      result.retried += pending.size();
    }
    const std::string job_id = Submit(pending, dir, job_name, options);
    ++result.submissions;
    HISFM_LOG_DEBUG("{}: job {} with {} task(s)", what, job_id,
                    pending.size());
    try {
      int squeue_failures = 0;
      while (true) {
        const size_t done = count_done();
        progress.Update(done);
        if (done == tasks.size()) break;
        if (!InQueue(job_id, options, &squeue_failures)) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(
            static_cast<int>(options.poll_seconds * 1000)));
        ThrowIfInterrupted();
      }
    } catch (...) {
      Cancel(job_id, options);
      throw;
    }
    std::vector<size_t> failed;
    for (size_t i : pending) {
      if (SlurmTaskDone(dir, i, tasks[i].fingerprint)) {
        ++result.ran;
      } else {
        failed.push_back(i);
      }
    }
    pending = failed;
  }
  progress.Finish();
  return result;
}

}  // namespace hisfm
