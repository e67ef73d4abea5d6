#include "hisfm/recon/slurm_feature_stages.h"

#include <algorithm>
#include <filesystem>
#include <set>

#include "hisfm/io/database_merge.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/recon/feature_pipeline.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;

namespace hisfm {

std::vector<IndexPairs> ExhaustivePairBlocks(size_t num_images,
                                             size_t group_size) {
  ThrowUnless(group_size > 0, "exhaustive pair blocks need a group size");
  const size_t groups = (num_images + group_size - 1) / group_size;
  std::vector<IndexPairs> blocks;
  for (size_t a = 0; a < groups; ++a) {
    for (size_t b = a; b < groups; ++b) {
      IndexPairs block;
      const size_t a_end = std::min(num_images, (a + 1) * group_size);
      const size_t b_end = std::min(num_images, (b + 1) * group_size);
      for (size_t i = a * group_size; i < a_end; ++i) {
        for (size_t j = std::max(b * group_size, i + 1); j < b_end; ++j) {
          block.emplace_back(i, j);
        }
      }
      if (!block.empty()) blocks.push_back(std::move(block));
    }
  }
  return blocks;
}

IndexPairs SequentialPairs(size_t num_images, size_t overlap,
                           bool quadratic_overlap) {
  std::set<std::pair<size_t, size_t>> pairs;
  for (size_t i = 0; i < num_images; ++i) {
    for (size_t k = 0; k < overlap; ++k) {
      const size_t j = i + k;
      if (j >= num_images) break;
      if (j != i) pairs.emplace(i, j);
      if (quadratic_overlap && k < 63) {
        const size_t q = i + (size_t{1} << k);
        if (q < num_images) pairs.emplace(i, q);
      }
    }
  }
  return IndexPairs(pairs.begin(), pairs.end());
}

std::vector<IndexPairs> CutPairs(const IndexPairs& pairs, size_t block_pairs) {
  ThrowUnless(block_pairs > 0, "pair blocks need a size");
  std::vector<IndexPairs> blocks;
  for (size_t start = 0; start < pairs.size(); start += block_pairs) {
    const size_t end = std::min(pairs.size(), start + block_pairs);
    blocks.emplace_back(pairs.begin() + start, pairs.begin() + end);
  }
  return blocks;
}

size_t PieceSize(size_t count, size_t pieces) {
  pieces = std::max<size_t>(pieces, 1);
  return std::max<size_t>(1, (count + pieces - 1) / pieces);
}

namespace {

std::string Join(const std::vector<std::string>& words) {
  std::string out;
  for (const std::string& w : words) out += " " + ShellQuote(w);
  return out;
}

// The colmap executable as the tasks run it (an absolute path, so that the
// nodes need not have the same PATH).
std::string TaskColmap(const ColmapRunnerOptions& colmap) {
  const std::string found = FindExecutable(colmap.colmap_path);
  ThrowUnless(!found.empty(),
              StrCat("colmap not found: cannot run '", colmap.colmap_path,
                     "'; install it with scripts/setup.sh or set "
                     "--colmap_path"));
  return found;
}

// Runs the command of a task with GLOG's logs in the task folder.
std::string ColmapCommand(const std::string& colmap,
                          const std::vector<std::string>& args) {
  return StrCat("GLOG_log_dir=\"$PWD\" ", ShellQuote(colmap), Join(args));
}

}  // namespace

size_t ExtractFeaturesOnSlurm(const SlurmExtractionJob& job,
                              const ColmapRunnerOptions& colmap,
                              const SlurmOptions& slurm,
                              const std::string& array_dir,
                              const std::string& output_path) {
  ThrowUnless(job.shard_size > 0, "feature shards need a size");
  const std::string colmap_exe = TaskColmap(colmap);
  fs::create_directories(array_dir);
  const std::string dir = fs::absolute(array_dir).lexically_normal();
  std::vector<SlurmTask> tasks;
  std::vector<std::string> shard_paths;
  for (size_t start = 0, k = 0; start < job.image_names.size();
       start += job.shard_size, ++k) {
    const size_t end =
        std::min(job.image_names.size(), start + job.shard_size);
    std::string list;
    for (size_t i = start; i < end; ++i) list += job.image_names[i] + "\n";
    const std::string list_path = StrCat(dir, "/shard_", k, ".txt");
    if (!fs::exists(list_path) || ReadTextFile(list_path) != list) {
      WriteFileAtomically(list_path, list);
    }
    const std::string db = StrCat(dir, "/shard_", k, ".db");
    const std::string tmp = StrCat(dir, "/shard_", k, ".tmp.db");
    std::vector<std::string> args = {
        "feature_extractor", "--database_path", tmp, "--image_path",
        job.image_path, "--image_list_path", list_path,
        "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads",
        StrCat(slurm.cpus_per_task), "--ImageReader.camera_model",
        job.camera_model};
    if (job.single_camera) {
      args.insert(args.end(), {"--ImageReader.single_camera", "1"});
    } else {
      args.insert(args.end(), {"--ImageReader.single_camera_per_image", "1"});
    }
    args.insert(args.end(), job.extractor_args.begin(),
                job.extractor_args.end());
    SlurmTask task;
    task.name = StrCat("feature shard ", k, " (images ", start + 1, "-", end,
                       ")");
    task.command = StrCat("rm -f ", ShellQuote(tmp), "\n",
                          ColmapCommand(colmap_exe, args), "\nmv ",
                          ShellQuote(tmp), " ", ShellQuote(db));
    task.fingerprint = TextFingerprint(
        StrCat(job.fingerprint, "\n", list, ShellQuote(colmap_exe)));
    tasks.push_back(std::move(task));
    shard_paths.push_back(db);
  }
  LogHeading(StrCat("Extracting features of ", job.image_names.size(),
                    " image(s) on Slurm: ", tasks.size(),
                    " shard(s) of at most ", job.shard_size, " image(s)"));
  Timer timer;
  const SlurmRunResult run = RunSlurmTasks(
      tasks, dir, "hisfm-features", "Feature shards", slurm);
  HISFM_LOG_INFO("feature shards: {} run, {} reused, {} retried ({:.1f} s)",
                 run.ran, run.reused, run.retried, timer.ElapsedSeconds());
  FeatureShardMergeOptions merge;
  merge.single_camera = job.single_camera;
  MergeFeatureShards(shard_paths, job.image_names, output_path, merge);
  RequireValidDatabase(output_path);
  return tasks.size();
}

size_t MatchOnSlurm(const SlurmMatchingJob& job,
                    const ColmapRunnerOptions& colmap,
                    const SlurmOptions& slurm, const std::string& array_dir,
                    const std::string& output_path) {
  const std::string colmap_exe = TaskColmap(colmap);
  fs::create_directories(array_dir);
  const std::string dir = fs::absolute(array_dir).lexically_normal();
  const bool retrieval = job.pair_blocks.empty();
  const size_t num_tasks =
      retrieval ? job.query_shards.size() : job.pair_blocks.size();
  std::vector<SlurmTask> tasks;
  std::vector<std::string> block_paths;
  for (size_t k = 0; k < num_tasks; ++k) {
    std::string list;
    if (retrieval) {
      for (size_t i : job.query_shards[k]) list += job.image_names[i] + "\n";
    } else {
      for (const auto& [i, j] : job.pair_blocks[k]) {
        list += job.image_names[i] + " " + job.image_names[j] + "\n";
      }
    }
    const std::string list_path = StrCat(dir, "/block_", k, ".txt");
    if (!fs::exists(list_path) || ReadTextFile(list_path) != list) {
      WriteFileAtomically(list_path, list);
    }
    const std::string db = StrCat(dir, "/block_", k, ".db");
    const std::string tmp = StrCat(dir, "/block_", k, ".tmp.db");
    std::vector<std::string> args;
    if (retrieval) {
      args = {"vocab_tree_matcher", "--database_path", tmp,
              "--VocabTreeMatching.vocab_tree_path", job.vocab_tree_path,
              "--VocabTreeMatching.num_images", StrCat(job.num_neighbors),
              "--VocabTreeMatching.match_list_path", list_path};
    } else {
      args = {"matches_importer", "--database_path", tmp,
              "--match_list_path", list_path, "--match_type", "pairs"};
    }
    args.insert(args.end(),
                {"--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads",
                 StrCat(slurm.cpus_per_task)});
    args.insert(args.end(), job.matcher_args.begin(), job.matcher_args.end());
    SlurmTask task;
    task.name = retrieval
                    ? StrCat("retrieval block ", k, " (",
                             job.query_shards[k].size(), " query image(s))")
                    : StrCat("pair block ", k, " (",
                             job.pair_blocks[k].size(), " pair(s))");
    task.command = StrCat("cp ", ShellQuote(job.features_path), " ",
                          ShellQuote(tmp), "\n",
                          ColmapCommand(colmap_exe, args), "\nmv ",
                          ShellQuote(tmp), " ", ShellQuote(db));
    task.fingerprint = TextFingerprint(
        StrCat(job.fingerprint, "\n", retrieval ? "retrieval\n" : "pairs\n",
               list, ShellQuote(colmap_exe)));
    tasks.push_back(std::move(task));
    block_paths.push_back(db);
  }
  LogHeading(StrCat("Matching ", job.image_names.size(),
                    " image(s) on Slurm: ", tasks.size(),
                    retrieval ? " retrieval block(s) (colmap "
                                "vocab_tree_matcher)"
                              : " pair block(s) (colmap matches_importer)"));
  Timer timer;
  const SlurmRunResult run = RunSlurmTasks(tasks, dir, "hisfm-matching",
                                           "Matching blocks", slurm);
  HISFM_LOG_INFO("matching blocks: {} run, {} reused, {} retried ({:.1f} s)",
                 run.ran, run.reused, run.retried, timer.ElapsedSeconds());
  const MatchBlockMergeStats stats =
      MergeMatchBlocks(job.features_path, block_paths, output_path);
  HISFM_LOG_INFO("merged {} block(s): {} matched and {} verified pair(s)",
                 block_paths.size(), stats.matched_pairs,
                 stats.verified_pairs);
  RequireValidDatabase(output_path);
  return tasks.size();
}

}  // namespace hisfm
