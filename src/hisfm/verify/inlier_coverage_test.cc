#include "hisfm/verify/inlier_coverage.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

// Cells counted the slow way: the set of (column, row) of the keypoints the
// matches index, on the grid the class documents (square cells of
// max(width, height) / grid_cells pixels).
int SlowCoveredCells(const Keypoints& k, int width, int height, int grid_cells,
                     const std::vector<FeatureMatch>& matches, bool first) {
  const double cell = static_cast<double>(std::max(width, height)) / grid_cells;
  const int nx = static_cast<int>(std::ceil(width / cell));
  const int ny = static_cast<int>(std::ceil(height / cell));
  std::set<std::pair<int, int>> cells;
  for (const FeatureMatch& m : matches) {
    const Point2DIdx idx = first ? m.idx1 : m.idx2;
    if (idx >= k.rows()) continue;
    cells.insert({std::clamp(static_cast<int>(k(idx, 0) / cell), 0, nx - 1),
                  std::clamp(static_cast<int>(k(idx, 1) / cell), 0, ny - 1)});
  }
  return static_cast<int>(cells.size());
}

TEST(CoverageGrid, CountsDistinctCellsOnSmallAndLargeGrids) {
  TempDir dir("hisfm-coverage");
  const std::string path = dir / "database.db";
  const int width = 1067, height = 800, num_keypoints = 500;
  std::mt19937 rng(23);
  std::vector<Keypoints> keypoints;
  {
    DatabaseWriter writer(path);
    writer.WriteCamera(SimplePinholeCamera(1, width, height, 900));
    for (ImageId id = 1; id <= 2; ++id) {
      writer.WriteImage({id, "im" + std::to_string(id), 1});
      Keypoints k(num_keypoints, 2);
      for (int r = 0; r < num_keypoints; ++r) {
        k(r, 0) = static_cast<float>(rng() % (width * 10)) / 10.0f;
        k(r, 1) = static_cast<float>(rng() % (height * 10)) / 10.0f;
      }
      writer.WriteKeypoints(id, k);
      keypoints.push_back(k);
    }
    writer.Close();
  }
  Database db(path);
  // 10 cells along the width: 10 x 8 cells, counted with a bit each; 30:
  // 30 x 23, counted with stamps.
  for (const int grid_cells : {10, 30}) {
    CoverageGrid grid(db, grid_cells);
    CoverageGrid::Scratch scratch;
    grid.Load(1);
    grid.Load(2);
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<FeatureMatch> matches(rng() % 300);
      for (FeatureMatch& m : matches) {
        // A few indices beyond the keypoints: ignored.
        m.idx1 = static_cast<Point2DIdx>(rng() % (num_keypoints + 3));
        m.idx2 = static_cast<Point2DIdx>(rng() % (num_keypoints + 3));
      }
      for (const bool first : {true, false}) {
        const ImageId id = first ? 1 : 2;
        const int expected = SlowCoveredCells(keypoints[id - 1], width, height,
                                              grid_cells, matches, first);
        EXPECT_EQ(grid.CoveredCells(id, matches, first, &scratch), expected)
            << "grid " << grid_cells << " trial " << trial;
        EXPECT_EQ(grid.CoveredCells(id, matches, first), expected);
      }
    }
    const int all_cells = grid_cells == 10 ? 80 : 30 * 23;
    EXPECT_LE(grid.TexturedCells(1), all_cells);
    EXPECT_GT(grid.TexturedCells(1), all_cells / 2);
  }
  CoverageGrid grid(db, 10);
  CoverageGrid::Scratch scratch;
  EXPECT_THROW(grid.CoveredCells(7, {}, true, &scratch), Error);
}

}  // namespace
}  // namespace hisfm
