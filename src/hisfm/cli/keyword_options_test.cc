#include "hisfm/cli/keyword_options.h"

#include <gtest/gtest.h>

#include <set>

#include "hisfm/cli/option_flags.h"

namespace hisfm {
namespace {

TEST(KeywordOptions, KeywordOfFlag) {
  EXPECT_EQ(KeywordOfFlag("--HiSfM.top_k"), "top_k");
  EXPECT_EQ(KeywordOfFlag("--log_level"), "log_level");
  EXPECT_EQ(KeywordOfFlag("--Mapper.ba_global_max_refinements"),
            "ba_global_max_refinements");
  EXPECT_EQ(KeywordOfFlag("-x"), "x");
}

// Every flag of `hisfm mapper` has a keyword of its own.
TEST(KeywordOptions, MapperFlagsHaveDistinctKeywords) {
  CLI::App app;
  MapperPaths paths;
  HierarchicalMapperOptions options;
  std::string log_level;
  AddMapperPathFlags(app, &paths);
  PrepareMapperCommand(app, &options, &log_level);
  const std::vector<std::string> keywords = KeywordsOf(app);
  const std::set<std::string> unique(keywords.begin(), keywords.end());
  EXPECT_EQ(unique.size(), keywords.size());
  for (const char* k : {"database_path", "work_path", "top_k",
                        "verify_threshold", "verifier", "colmap_path",
                        "log_level", "scaffold_ba_global_ratio"}) {
    EXPECT_EQ(unique.count(k), 1u) << k;
  }
  // Help and the options file are not options.
  EXPECT_EQ(unique.count("help"), 0u);
  EXPECT_EQ(unique.count("project_path"), 0u);
}

TEST(KeywordOptions, ParsesThroughTheFlags) {
  CLI::App app;
  HierarchicalMapperOptions options;
  std::string log_level = "info";
  AddHierarchicalMapperFlags(app, &options);
  ParseKeywords(app, {{"top_k", "2"},
                      {"verify_threshold", "0.8"},
                      {"filter_pairs", "false"},
                      {"verifier", "none"}});
  EXPECT_EQ(options.hierarchy.communities.top_k, 2);
  EXPECT_DOUBLE_EQ(options.hierarchy.skeleton.verify_threshold, 0.8);
  EXPECT_FALSE(options.verifier.filter_pairs);
  EXPECT_EQ(options.verifier.verifier, "none");
}

TEST(KeywordOptions, UnknownRepeatedAndBadValuesAreNamed) {
  auto error_of = [](const std::vector<std::pair<std::string, std::string>>&
                         keywords,
                     bool* unknown) {
    CLI::App app;
    HierarchicalMapperOptions options;
    AddHierarchicalMapperFlags(app, &options);
    try {
      ParseKeywords(app, keywords);
    } catch (const UnknownKeyword& e) {
      *unknown = true;
      return std::string(e.what());
    } catch (const BadKeywordValue& e) {
      *unknown = false;
      return std::string(e.what());
    }
    return std::string();
  };
  bool unknown = false;
  EXPECT_EQ(error_of({{"top_kk", "1"}}, &unknown), "unknown option 'top_kk'");
  EXPECT_TRUE(unknown);
  EXPECT_EQ(error_of({{"top_k", "1"}, {"top_k", "2"}}, &unknown),
            "option 'top_k' given twice");
  EXPECT_TRUE(unknown);
  const std::string bad = error_of({{"top_k", "many"}}, &unknown);
  EXPECT_FALSE(unknown);
  EXPECT_NE(bad.find("top_k"), std::string::npos) << bad;
  EXPECT_NE(bad.find("many"), std::string::npos) << bad;
  EXPECT_EQ(bad.find('\n'), std::string::npos);
}

}  // namespace
}  // namespace hisfm
