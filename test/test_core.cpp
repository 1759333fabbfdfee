// Core types: gripper configs load and validate, grasp frames are right-handed,
// line fit and PCA match hand-computed values.
#include "fast_grasp/grasping/grasp_geometry.h"
#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace fast_grasp;

TEST(GripperModel, ShippedGrippersLoad)
{
  for (const char* name : { "lacquey_fetch", "robotiq_2f85", "pr2" })
  {
    const GripperModel g = loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/" + name + ".yaml");
    EXPECT_EQ(g.name, name);
    EXPECT_TRUE(g.validate().empty()) << g.validate();
    EXPECT_GT(g.cshape_r2_m, g.cshape_r1_m);
  }
  EXPECT_NEAR(loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/robotiq_2f85.yaml").max_opening_m,
              0.085, 1e-9);
}

TEST(GripperModel, MissingKeyAndFileAreClearErrors)
{
  EXPECT_THROW(loadGripperModel("/nonexistent/gripper.yaml"), std::runtime_error);
  const std::string path = ::testing::TempDir() + "/bad_gripper.yaml";
  std::ofstream(path) << "name: bad\nmax_opening_m: 0.1\n";
  try
  {
    loadGripperModel(path);
    FAIL() << "expected an exception";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("finger_width_m"), std::string::npos) << e.what();
  }
}

TEST(GripperModel, DimensionsAboveAMetreAreRejected)
{
  // Found by fuzzing the C-shape planner (corpus/object_view/crash_cshape_r2_15_km): with
  // cshape_r2_m = 15728 m one plan() ran for seconds under the sanitizers.
  GripperModel g = loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/robotiq_2f85.yaml");
  ASSERT_TRUE(g.validate().empty());
  g.cshape_r2_m = 15728.64;
  EXPECT_NE(g.validate().find("cshape_r2_m must be a positive number of metres up to 1"), std::string::npos)
      << g.validate();
  g.cshape_r2_m = 1.0;  // a metre is still a (large) hand
  EXPECT_TRUE(g.validate().empty()) << g.validate();
}

TEST(GraspTypes, PoseIsRightHandedAndExposesGpdVectors)
{
  GraspCandidate g;
  g.pose = makeGraspPose(Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0, 0, -2), Eigen::Vector3d(1, 0, 0.5));
  EXPECT_TRUE(g.approach().isApprox(Eigen::Vector3d(0, 0, -1)));
  EXPECT_TRUE(g.binormal().isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(g.axis().isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_NEAR(g.pose.linear().determinant(), 1.0, 1e-12);
  EXPECT_TRUE(g.position().isApprox(Eigen::Vector3d(1, 2, 3)));
}

TEST(GraspTypes, SortBestFirst)
{
  std::vector<GraspCandidate> grasps(3);
  grasps[0].score = 0.1;
  grasps[1].score = 0.9;
  grasps[2].score = 0.5;
  sortGraspsBestFirst(grasps);
  EXPECT_DOUBLE_EQ(grasps[0].score, 0.9);
  EXPECT_DOUBLE_EQ(grasps[2].score, 0.1);
}

TEST(GraspGeometry, LineFitMatchesHandComputation)
{
  // y = 2x + 1 exactly.
  const LineFit fit = fitLine({ { 0, 1 }, { 1, 3 }, { 2, 5 }, { 3, 7 } });
  EXPECT_NEAR(fit.k, 2.0, 1e-12);
  EXPECT_NEAR(fit.b, 1.0, 1e-12);
  EXPECT_NEAR(fit.angleRad(), std::atan(2.0), 1e-12);
  EXPECT_TRUE(fitLine({ { 1, 0 }, { 1, 1 }, { 1, 2 } }).vertical);
}

TEST(GraspGeometry, ClosingBridgesOneCellGapsAndKeepsTheOutline)
{
  // 9 x 7 grid, 2 empty cells of padding: a 5 x 3 block with a one-cell hole in its middle
  // and a one-cell notch in its top edge. One closing iteration fills both and nothing else.
  const int cols = 9, rows = 7;
  std::vector<std::uint8_t> grid(cols * rows, 0);
  auto at = [cols](int c, int r) { return static_cast<std::size_t>(r * cols + c); };
  for (int r = 2; r <= 4; ++r)
    for (int c = 2; c <= 6; ++c)
      grid[at(c, r)] = 1;
  grid[at(4, 3)] = 0;  // hole
  grid[at(3, 4)] = 0;  // notch in the top edge
  std::vector<std::uint8_t> expected(cols * rows, 0);
  for (int r = 2; r <= 4; ++r)
    for (int c = 2; c <= 6; ++c)
      expected[at(c, r)] = 1;
  closeBinaryGrid(grid, cols, rows, 1);
  EXPECT_EQ(grid, expected);
  // Zero iterations and a grid of the wrong size leave it as it is.
  std::vector<std::uint8_t> copy = grid;
  closeBinaryGrid(copy, cols, rows, 0);
  EXPECT_EQ(copy, grid);
  closeBinaryGrid(copy, cols + 1, rows, 1);
  EXPECT_EQ(copy, grid);
}

TEST(GraspGeometry, PcaOfABoxFindsItsLongSide)
{
  CloudXYZ cloud;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 4; ++j)
      cloud.push_back(PointXYZ(0.01f * j, 0.0f, 0.05f * i));  // 0.04 x 1.0 sheet along z
  cloud.push_back(PointXYZ(std::nanf(""), 0, 0));
  const PrincipalFrame frame = computePrincipalFrame(cloud);
  EXPECT_EQ(frame.point_count, 105u);
  EXPECT_NEAR(std::abs(frame.axes.col(0).z()), 1.0, 1e-5);
  EXPECT_NEAR(frame.centroid.z(), 0.5, 1e-5);
  EXPECT_NEAR(frame.centroid.x(), 0.02, 1e-5);
  EXPECT_NEAR(frame.axes.determinant(), 1.0, 1e-5);
}
