#!/usr/bin/env bash
# Builds HiSfM a second time with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer into build-sanitize/ and runs the test suite
# there (any sanitizer report fails its test), then runs each libFuzzer
# target of tests/fuzz for HISFM_FUZZ_SECONDS (default 25) from its
# checked-in corpus (libFuzzer seed HISFM_FUZZ_SEED, default 1; 0 draws a
# new one) and prints the executions per target. Needs the packages
# of scripts/setup.sh (clang, libclang-rt-14-dev); .ci/run calls it after
# scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
export HISFM_DATA_DIR="${HISFM_DATA_DIR:-$(cd .. && pwd)/shared/data}"
FUZZ_SECONDS="${HISFM_FUZZ_SECONDS:-25}"
FUZZ_SEED="${HISFM_FUZZ_SEED:-1}"
start=$(date +%s)

echo "==> Building build-sanitize (clang, -fsanitize=address,undefined, libFuzzer)"
cmake -S . -B build-sanitize -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS="-O1 -gline-tables-only" \
  -DHISFM_SANITIZE=ON -DHISFM_BUILD_FUZZERS=ON -DHISFM_BUILD_BENCHMARKS=OFF \
  -DHISFM_FUZZ_SECONDS="$FUZZ_SECONDS" -DHISFM_FUZZ_SEED="$FUZZ_SEED" > /dev/null
cmake --build build-sanitize -j"$(nproc)"
built=$(date +%s)

cd build-sanitize
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
echo "==> Test suite under ASan/UBSan"
# Except the end-to-end runs on the shared real scenes (feature extraction,
# matching, verification of every pair and mapping of real photos; 5 to 15
# minutes each under the sanitizers): scripts/test.sh runs them, and the code
# of hisfm they reach runs here in the synthetic pipeline tests (the sequence
# pass of the oats test in SequencePassUnfoldsARepeatedStreet and
# RegistersAllCupImages, and in sequence_pass_test). Likewise two
# synthetic end-to-end tests, 10 and 5 minutes each here:
# - MergesSubModelsAndReseedsWhatTheAttachLeaves (150 images): the merge
#   itself runs here in model_merge_test, the re-seeding and a refused merge
#   in ReseededModelsAreJoinedOrWrittenApart; the mapper's steps after a
#   merge that succeeds run in the release suite only;
# - PlugInVerifierJudgesTheTrustedEdges (two mapper runs): a plug-in judging
#   trusted edges runs here in PlugInVerifierScoresSupportEdges, its
#   rejections in trusted_edges_test and verified_hierarchy_test.
ctest --output-on-failure -j2 --timeout 1800 -LE fuzz \
  -E 'ReconstructSlurm\.BooksGivesTheLocalDatabase|HierarchicalMapper\.(Cup|Books|FacadeStreet60)IsCorrect(WhereColmapFolds|AtThePapersTau)|HierarchicalMapper\.OatsAgreesWithItsConsecutivePhotos|HierarchicalMapper\.(MergesSubModelsAndReseedsWhatTheAttachLeaves|PlugInVerifierJudgesTheTrustedEdges)|ExhaustiveFilter\.DropsRejectedPairsAndKeepsTheInput|ReconstructionReport\.BooksPhotosToReport'
tested=$(date +%s)

echo "==> Fuzzing, ${FUZZ_SECONDS} s per target"
# From the checked-in corpus alone: what earlier runs found is dropped.
find fuzz/work -type f -delete
ctest --output-on-failure -j2 -L fuzz
# libFuzzer's final statistics of each target, from ctest's log.
awk '/^[0-9]+\/[0-9]+ Test: fuzz\./ { name = $3 }
     /^stat::number_of_executed_units/ { runs[name] = $2 }
     /^stat::new_units_added/ { added[name] = $2 }
     /^stat::peak_rss_mb/ { rss[name] = $2 }
     END { for (n in runs) printf "%-30s %10d executions, %4d new inputs, peak %d MB\n", n, runs[n], added[n], rss[n] }' \
  Testing/Temporary/LastTest.log | sort
echo "==> Sanitizer build $((built - start)) s, tests $((tested - built)) s, fuzzing $(( $(date +%s) - tested )) s"
