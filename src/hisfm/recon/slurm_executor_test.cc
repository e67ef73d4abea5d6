#include "hisfm/recon/slurm_executor.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// Stand-ins for sbatch and squeue: sbatch runs the array's tasks one after
// the other before it returns (as a cluster that ran them at once would
// leave them) and records each --array spec, one a line; squeue then finds
// nothing in the queue.
class FakeSlurm {
 public:
  explicit FakeSlurm(const std::string& dir) : dir_(dir) {
    fs::create_directories(dir);
    Write(dir + "/sbatch", R"(#!/bin/bash
spec=""; chdir=""; out=""
for a in "$@"; do
  case "$a" in
    --array=*) spec="${a#--array=}"; spec="${spec%%\%*}" ;;
    --chdir=*) chdir="${a#--chdir=}" ;;
    --output=*) out="${a#--output=}" ;;
  esac
  script="$a"
done
echo "$spec" >> ")" + SubmissionsFile() + R"("
cd "$chdir" || exit 1
IFS=',' read -ra parts <<< "$spec"
for p in "${parts[@]}"; do
  if [[ "$p" == *-* ]]; then first="${p%-*}"; last="${p#*-}"; else first="$p"; last="$p"; fi
  for ((i = first; i <= last; i++)); do
    SLURM_ARRAY_TASK_ID=$i bash "$script" >> "${out//%a/$i}" 2>&1
  done
done
echo "42"
)");
    Write(dir + "/squeue", "#!/bin/bash\nexit 0\n");
    Write(dir + "/scancel", "#!/bin/bash\nexit 0\n");
  }
  SlurmOptions Options() const {
    SlurmOptions o;
    o.sbatch_path = dir_ + "/sbatch";
    o.squeue_path = dir_ + "/squeue";
    o.scancel_path = dir_ + "/scancel";
    return o;
  }
  std::string SubmissionsFile() const { return dir_ + "/submissions.txt"; }

 private:
  static void Write(const std::string& path, const std::string& text) {
    std::ofstream(path) << text;
    chmod(path.c_str(), 0755);
  }
  std::string dir_;
};

// Tasks that append their name to a file; task `flaky` fails on its first
// attempt (a mark file remembers it), task `broken` always fails.
std::vector<SlurmTask> CountingTasks(const std::string& dir, int n,
                                     int flaky = -1, int broken = -1) {
  std::vector<SlurmTask> tasks;
  for (int i = 0; i < n; ++i) {
    SlurmTask t;
    t.name = StrCat("shard ", i);
    t.fingerprint = StrCat("fp", i);
    t.command = StrCat("echo ", i, " >> ", ShellQuote(dir + "/ran.txt"));
    if (i == flaky) {
      const std::string mark = dir + "/flaky.mark";
      t.command += StrCat("\nif [ ! -f ", ShellQuote(mark), " ]; then touch ",
                          ShellQuote(mark), "; exit 3; fi");
    }
    if (i == broken) t.command += "\necho 'no such input' >&2; exit 4";
    tasks.push_back(std::move(t));
  }
  return tasks;
}

std::vector<std::string> Lines(const std::string& path) {
  std::vector<std::string> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) out.push_back(line);
  return out;
}

TEST(ShellQuote, QuotesEveryWord) {
  EXPECT_EQ(ShellQuote("a b"), "'a b'");
  EXPECT_EQ(ShellQuote("it's"), "'it'\\''s'");
  EXPECT_EQ(ShellQuote(""), "''");
  EXPECT_EQ(FindExecutable("sh").front(), '/');
  EXPECT_EQ(FindExecutable("no-such-program-hisfm"), "");
}

TEST(RunSlurmTasks, RunsResumesAndRetriesWithFakeSlurm) {
  TempDir tmp;
  const FakeSlurm fake(tmp / "bin");
  SlurmOptions options = fake.Options();
  options.poll_seconds = 0.05;
  const std::string dir = tmp / "array";
  fs::create_directories(dir);

  // Five tasks, one fails once: two submissions, the second of one task.
  SlurmRunResult r =
      RunSlurmTasks(CountingTasks(dir, 5, 2), dir, "t", "Shards", options);
  EXPECT_EQ(r.ran, 5u);
  EXPECT_EQ(r.reused, 0u);
  EXPECT_EQ(r.submissions, 2u);
  EXPECT_EQ(r.retried, 1u);
  EXPECT_EQ(Lines(fake.SubmissionsFile()),
            (std::vector<std::string>{"0-4", "2"}));
  EXPECT_EQ(Lines(dir + "/ran.txt").size(), 6u);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(SlurmTaskDone(dir, i, StrCat("fp", i)));
  // The log of the flaky task has both attempts.
  EXPECT_NE(ReadTextFile(dir + "/task_2.log").find("attempt"),
            std::string::npos);

  // A rerun submits nothing; a changed task alone is run again.
  r = RunSlurmTasks(CountingTasks(dir, 5), dir, "t", "Shards", options);
  EXPECT_EQ(r.reused, 5u);
  EXPECT_EQ(r.submissions, 0u);
  std::vector<SlurmTask> changed = CountingTasks(dir, 5);
  changed[3].fingerprint = "new";
  r = RunSlurmTasks(changed, dir, "t", "Shards", options);
  EXPECT_EQ(r.reused, 4u);
  EXPECT_EQ(r.ran, 1u);
  EXPECT_EQ(Lines(fake.SubmissionsFile()).back(), "3");
  // A lost output mark (a task's outputs removed by hand) is redone too.
  fs::remove(dir + "/task_0.done");
  r = RunSlurmTasks(changed, dir, "t", "Shards", options);
  EXPECT_EQ(r.ran, 1u);
  EXPECT_EQ(Lines(fake.SubmissionsFile()).back(), "0");
}

TEST(RunSlurmTasks, NamesATaskThatKeepsFailing) {
  TempDir tmp;
  const FakeSlurm fake(tmp / "bin");
  SlurmOptions options = fake.Options();
  options.poll_seconds = 0.05;
  options.max_retries = 2;
  const std::string dir = tmp / "array";
  fs::create_directories(dir);
  try {
    RunSlurmTasks(CountingTasks(dir, 4, -1, 1), dir, "t", "Shards", options);
    FAIL() << "a failing task was not reported";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("1 of 4 task(s) still failed after 2 retries"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("shard 1"), std::string::npos) << m;
    EXPECT_NE(m.find("task_1.log"), std::string::npos) << m;
    EXPECT_NE(m.find("no such input"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  // Three attempts of the broken task, one of each other.
  EXPECT_EQ(Lines(fake.SubmissionsFile()),
            (std::vector<std::string>{"0-3", "1", "1"}));
  EXPECT_EQ(Lines(dir + "/ran.txt").size(), 6u);
  EXPECT_FALSE(SlurmTaskDone(dir, 1, "fp1"));
  EXPECT_TRUE(SlurmTaskDone(dir, 3, "fp3"));
}

TEST(RunSlurmTasks, SbatchFailureIsOneLine) {
  TempDir tmp;
  const std::string dir = tmp / "array";
  SlurmOptions options;
  options.sbatch_path = "/bin/false";
  try {
    RunSlurmTasks(CountingTasks(dir, 1), dir, "t", "Shards", options);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sbatch failed"), std::string::npos);
  }
  options.sbatch_path = tmp / "no-sbatch";
  try {
    RunSlurmTasks(CountingTasks(dir, 1), dir, "t", "Shards", options);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is Slurm installed"),
              std::string::npos);
  }
}

// On the one-machine cluster of scripts/local_slurm.sh that ctest starts
// (skipped where Slurm is not installed).
TEST(RunSlurmTasks, RunsOnTheLocalCluster) {
  const std::string skip = UseLocalSlurmCluster();
  if (!skip.empty()) GTEST_SKIP() << skip;
  TempDir tmp;
  const std::string dir = tmp / "array";
  fs::create_directories(dir);
  SlurmOptions options;
  options.poll_seconds = 0.2;
  const SlurmRunResult r =
      RunSlurmTasks(CountingTasks(dir, 3, 1), dir, "hisfm-test", "Shards",
                    options);
  EXPECT_EQ(r.ran, 3u);
  EXPECT_EQ(r.retried, 1u);
  EXPECT_EQ(Lines(dir + "/ran.txt").size(), 4u);
  EXPECT_NE(ReadTextFile(dir + "/task_0.log").find("shard 0: attempt"),
            std::string::npos);
}

}  // namespace
}  // namespace hisfm
