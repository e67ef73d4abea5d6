// Runs a list of shell tasks as a Slurm job array (`sbatch --array`) on a
// filesystem shared by the submitting machine and the cluster's nodes, and
// waits for them with progress, bounded retries and resumption.
//
// Each task is a shell command that writes its outputs under temporary
// names and renames them into place. The executor wraps it in a script that
// writes a done mark (the task's fingerprint) only when the command
// succeeds, so that:
//   - a task whose done mark holds its current fingerprint is not run again
//     (a rerun redoes only the missing or changed tasks);
//   - a task without a done mark after its array finished failed (or was
//     lost with its node) and is submitted again, up to max_retries times;
//     one still failing is named with its log in the error.
// Progress (tasks done/total) comes from counting done marks while the job
// is in the queue (`squeue`); Ctrl-C or SIGTERM cancels the job (`scancel`).
#pragma once

#include <string>
#include <vector>

namespace hisfm {

struct SlurmOptions {
  /// Slurm's commands (searched on PATH when they have no slash).
  std::string sbatch_path = "sbatch";
  std::string squeue_path = "squeue";
  std::string scancel_path = "scancel";
  /// Partition (--partition); empty: the cluster's default.
  std::string partition;
  /// CPUs of each task (--cpus-per-task); the colmap calls of a task use as
  /// many threads.
  int cpus_per_task = 1;
  /// Memory of each task in MB (--mem); 0: the cluster's default.
  int mem_mb = 0;
  /// Time limit of each task in minutes (--time); 0: the partition's.
  int time_limit_minutes = 0;
  /// At most this many tasks of an array run at once (--array=...%N); 0: no
  /// limit.
  int max_parallel_tasks = 0;
  /// Submissions of a failing task after its first (2: three attempts).
  int max_retries = 2;
  /// Seconds between two looks at the queue.
  double poll_seconds = 1.0;
  /// Further sbatch arguments, e.g. {"--account", "proj"}.
  std::vector<std::string> sbatch_args;

  void Check() const;
};

/// One task of an array.
struct SlurmTask {
  /// Short name used in messages and file names ("shard 3", "block 0-2").
  std::string name;
  /// Shell command (bash) run from the array's folder.
  std::string command;
  /// Fingerprint of the task's inputs; a done mark holding it makes the task
  /// count as done.
  std::string fingerprint;
};

/// What RunSlurmTasks did.
struct SlurmRunResult {
  /// Tasks found done from an earlier run (not submitted).
  size_t reused = 0;
  /// Tasks run in this call.
  size_t ran = 0;
  /// Submissions (arrays) in this call, retries included.
  size_t submissions = 0;
  /// Task runs that failed and were submitted again.
  size_t retried = 0;
};

/// Runs `tasks` as Slurm job arrays named `job_name` from the folder
/// `array_dir` (created; on the shared filesystem), where task i keeps its
/// script task_<i>.sh, its log task_<i>.log and its done mark task_<i>.done.
/// Reports progress as "`what`: done/total". Throws hisfm::Error if sbatch
/// fails, or naming the tasks (and the end of their logs) that still fail
/// after max_retries resubmissions.
SlurmRunResult RunSlurmTasks(const std::vector<SlurmTask>& tasks,
                             const std::string& array_dir,
                             const std::string& job_name,
                             const std::string& what,
                             const SlurmOptions& options);

/// True if task `index` of `array_dir` is done with `fingerprint`.
bool SlurmTaskDone(const std::string& array_dir, size_t index,
                   const std::string& fingerprint);

/// Quotes a word for a bash command line ('it'\''s').
std::string ShellQuote(const std::string& word);

/// The absolute path of an executable found on PATH (or `name` itself if it
/// has a slash); "" if not found.
std::string FindExecutable(const std::string& name);

}  // namespace hisfm
