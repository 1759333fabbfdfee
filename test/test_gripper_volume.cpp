// The real hand's volume (gripper_volume.h): boxes from the gripper YAML, and the final check
// every planner applies (back the palm out of the object, fingers free, object in between),
// against hand-computed coordinates.
#include "fast_grasp/grasping/gripper_volume.h"

#include <gtest/gtest.h>

using namespace fast_grasp;

namespace
{
GripperModel lacquey()
{
  return loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/lacquey_fetch.yaml");
}

/// Points on a 2 mm grid filling the axis-aligned box [lo, hi] (grasp coordinates = base).
CloudXYZ solidBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi)
{
  CloudXYZ cloud;
  for (float x = lo.x(); x <= hi.x() + 1e-6f; x += 0.002f)
    for (float y = lo.y(); y <= hi.y() + 1e-6f; y += 0.002f)
      for (float z = lo.z(); z <= hi.z() + 1e-6f; z += 0.002f)
        cloud.push_back(PointXYZ(x, y, z));
  return cloud;
}

void expectBox(const GripperBox& box, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi)
{
  EXPECT_TRUE(box.min.isApprox(lo, 1e-6f)) << box.min.transpose() << " vs " << lo.transpose();
  EXPECT_TRUE(box.max.isApprox(hi, 1e-6f)) << box.max.transpose() << " vs " << hi.transpose();
}
}  // namespace

TEST(GripperVolume, BoxesMatchTheLacqueyDrawing)
{
  // lacquey_fetch.yaml: finger depth 0.09, thickness 0.018, width 0.022, palm 0.07 deep and
  // 0.06 wide (the URDF's palm box), open 0.13.
  const auto boxes = openGripperBoxes(lacquey(), 0.13);
  expectBox(boxes[0], { -0.045f, 0.065f, -0.011f }, { 0.045f, 0.083f, 0.011f });
  expectBox(boxes[1], { -0.045f, -0.083f, -0.011f }, { 0.045f, -0.065f, 0.011f });
  expectBox(boxes[2], { -0.115f, -0.083f, -0.03f }, { -0.045f, 0.083f, 0.03f });
  expectBox(closingRegionBox(lacquey(), 0.04, 0.005), { -0.045f, -0.025f, -0.011f }, { 0.045f, 0.025f, 0.011f });
}

TEST(GripperVolume, PalmIsBackedOutOfTheObjectByTheExactOverlap)
{
  // A 4 cm wide block whose near face is 6 cm behind the grasp origin: the palm face (4.5 cm
  // behind) is 1.5 cm inside it, so the hand backs out by 0.015 + 0.003 clearance = 0.018 m
  // along -approach. The grasp approaches along base -Z here, to exercise the rotation.
  const GripperModel gripper = lacquey();
  Eigen::Isometry3d pose = makeGraspPose(Eigen::Vector3d(0.5, 0.1, 0.2), Eigen::Vector3d(0, 0, -1),
                                         Eigen::Vector3d(1, 0, 0));
  // In grasp coordinates x in [-0.06, 0.02], |y|, |z| <= 0.02; in base: z = 0.2 - x.
  CloudXYZ block;
  for (const auto& p : solidBox({ -0.06f, -0.02f, -0.02f }, { 0.02f, 0.02f, 0.02f }).points)
  {
    const Eigen::Vector3f base = (pose * p.getVector3fMap().cast<double>()).cast<float>();
    block.push_back(PointXYZ(base.x(), base.y(), base.z()));
  }
  GripperFitParams params;
  params.palm_clearance_m = 0.003;
  params.max_backoff_m = 0.03;
  GripperVolumeCheck check(gripper, params);
  check.addSeen(block);

  const GripperFit fit = check.fit(pose, 0.04);
  ASSERT_TRUE(fit.ok) << fit.why;
  EXPECT_NEAR(fit.backoff_m, 0.018, 1e-5);
  EXPECT_TRUE(fit.pose.translation().isApprox(Eigen::Vector3d(0.5, 0.1, 0.218), 1e-5)) << fit.pose.translation();
  EXPECT_TRUE(fit.pose.linear().isApprox(pose.linear()));
  EXPECT_EQ(fit.seen_in_gripper, 0u);
  // Between the fingers after the back-off: grasp x in [-0.045, 0.02 + 0.018 - ...]: the
  // block's points with x + 0.018 <= 0.045 (all of it), |y| <= 0.025, |z| <= 0.011.
  std::size_t expected_between = 0;
  for (const auto& p : solidBox({ -0.06f, -0.02f, -0.02f }, { 0.02f, 0.02f, 0.02f }).points)
    if (p.x + 0.018f >= -0.045f && std::abs(p.z) <= 0.011f)
      ++expected_between;
  EXPECT_EQ(fit.points_between_fingers, expected_between);

  // A hand allowed to back out by 1 cm only rejects the grasp and says why.
  params.max_backoff_m = 0.01;
  GripperVolumeCheck strict(gripper, params);
  strict.addSeen(block);
  const GripperFit rejected = strict.fit(pose, 0.04);
  EXPECT_FALSE(rejected.ok);
  EXPECT_NE(rejected.why.find("max_backoff_m"), std::string::npos) << rejected.why;
}

TEST(GripperVolume, ObjectWiderThanTheOpeningOrUnseenPartInTheFingersIsRejected)
{
  const GripperModel gripper = lacquey();
  const Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  // 15 cm wide (|y| <= 0.075): its sides are inside both open fingers (0.065 .. 0.083).
  GripperVolumeCheck wide(gripper, GripperFitParams{});
  wide.addSeen(solidBox({ -0.01f, -0.075f, -0.005f }, { 0.01f, 0.075f, 0.005f }));
  const GripperFit fit = wide.fit(pose, 0.15);
  EXPECT_FALSE(fit.ok);
  EXPECT_GT(fit.seen_in_gripper, 0u);
  EXPECT_NE(fit.why.find("open fingers"), std::string::npos) << fit.why;

  // A 4 cm object is fine, until unseen-part points fill the space of the +y finger.
  GripperVolumeCheck occluded(gripper, GripperFitParams{});
  occluded.addSeen(solidBox({ -0.02f, -0.02f, -0.01f }, { 0.02f, 0.02f, 0.01f }));
  EXPECT_TRUE(occluded.fit(pose, 0.04).ok);
  occluded.addUnseen(solidBox({ 0.0f, 0.066f, -0.004f }, { 0.02f, 0.08f, 0.004f }));
  const GripperFit hidden = occluded.fit(pose, 0.04);
  EXPECT_FALSE(hidden.ok);
  EXPECT_GT(hidden.unseen_in_gripper, 0u);
  EXPECT_EQ(hidden.seen_in_gripper, 0u);
}

TEST(GripperVolume, HandFromAboveIsRaisedOffTheTableAndASideHandBelowItIsDropped)
{
  // A 3 cm high bar on the table z = 0, grasped from above with the origin at its mid-height
  // (z = 0.015): the open fingers reach finger_depth / 2 = 0.045 m below the origin, to
  // z = -0.03. With a 1 cm table clearance the hand is raised by 0.01 + 0.03 = 0.04 m.
  const GripperModel gripper = lacquey();
  CloudXYZ bar = solidBox({ -0.1f, -0.015f, 0.0f }, { 0.1f, 0.015f, 0.03f });
  GripperFitParams params;
  params.max_backoff_m = 0.045;
  params.table_clearance_m = 0.01;
  GripperVolumeCheck check(gripper, params);
  check.addSeen(bar);
  check.setTable(Eigen::Vector4f(0, 0, -2, 0));  // not unit, pointing down: turned toward the bar
  const Eigen::Isometry3d from_above =
      makeGraspPose(Eigen::Vector3d(0, 0, 0.015), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  const GripperFit fit = check.fit(from_above, 0.03);
  ASSERT_TRUE(fit.ok) << fit.why;
  EXPECT_NEAR(fit.backoff_m, 0.04, 1e-4);
  EXPECT_NEAR(fit.pose.translation().z(), 0.055, 1e-4);
  EXPECT_NEAR(fit.lowest_above_table_m, 0.01, 1e-4);
  EXPECT_GT(fit.points_between_fingers, 0u);  // the bar's top 2 cm

  // Allowed to back out by 3 cm only: the fingertips would stay 1 cm under the clearance.
  params.max_backoff_m = 0.03;
  GripperVolumeCheck short_reach(gripper, params);
  short_reach.addSeen(bar);
  short_reach.setTable(Eigen::Vector4f(0, 0, 1, 0));
  const GripperFit too_low = short_reach.fit(from_above, 0.03);
  EXPECT_FALSE(too_low.ok);
  EXPECT_TRUE(too_low.blocked_by_table);
  // The reason quotes the height reached at the 3 cm limit (z = -0.03 + 0.03 = 0), not the
  // 1 cm the needed 4 cm back-off would give.
  EXPECT_NE(too_low.why.find("at the largest back-off"), std::string::npos) << too_low.why;
  EXPECT_EQ(too_low.why.find("stays 0.01 m"), std::string::npos) << too_low.why;
  EXPECT_FALSE(fit.blocked_by_table);

  // From the side (approach +x, closing +y) at z = 0.015: the palm, 0.06 m wide across the
  // closing plane (z here), reaches z = -0.015; backing out along x cannot raise it.
  const Eigen::Isometry3d from_side = makeGraspPose(Eigen::Vector3d(-0.0, 0, 0.015), Eigen::Vector3d(1, 0, 0),
                                                    Eigen::Vector3d(0, 1, 0));
  GripperVolumeCheck side(gripper, GripperFitParams{});
  side.addSeen(solidBox({ -0.01f, -0.015f, 0.0f }, { 0.01f, 0.015f, 0.03f }));
  side.setTable(Eigen::Vector4f(0, 0, 1, 0));
  const GripperFit dropped = side.fit(from_side, 0.03);
  EXPECT_FALSE(dropped.ok);
  EXPECT_TRUE(dropped.blocked_by_table);
  EXPECT_NE(dropped.why.find("table"), std::string::npos) << dropped.why;
}

TEST(GripperVolume, NothingBetweenTheFingersIsNoGrasp)
{
  // The object lies beside the finger plane (z > finger width / 2): nothing to squeeze.
  GripperVolumeCheck check(lacquey(), GripperFitParams{});
  check.addSeen(solidBox({ -0.02f, -0.02f, 0.03f }, { 0.02f, 0.02f, 0.05f }));
  const GripperFit fit = check.fit(Eigen::Isometry3d::Identity(), 0.04);
  EXPECT_FALSE(fit.ok);
  EXPECT_EQ(fit.points_between_fingers, 0u);
  EXPECT_NE(fit.why.find("between the fingers"), std::string::npos) << fit.why;
}

TEST(GripperVolume, FilterKeepsFittedGraspsWithTheirBackedOffPoseAndDropsTheRest)
{
  GripperVolumeCheck check(lacquey(), GripperFitParams{});
  check.addSeen(solidBox({ -0.06f, -0.02f, -0.02f }, { 0.02f, 0.02f, 0.02f }));
  std::vector<GraspCandidate> grasps(2);
  // Identity pose: the palm face (-0.045) is 0.015 m inside the block (near face -0.06); with
  // the default 0.011 m clearance the hand backs out by 0.026 m (within 0.045 - 0.005).
  grasps[0].width_m = 0.04;
  grasps[1].width_m = 0.04;
  grasps[1].pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.2);  // far above: nothing between
  std::string why;
  EXPECT_EQ(check.filter(grasps, &why), 1u);
  ASSERT_EQ(grasps.size(), 1u);
  EXPECT_NEAR(grasps[0].position().x(), -0.026, 1e-5);
  EXPECT_NE(why.find("between the fingers"), std::string::npos) << why;

  GripperFitParams off;
  off.enabled = false;
  GripperVolumeCheck disabled(lacquey(), off);
  std::vector<GraspCandidate> untouched(1);
  EXPECT_EQ(disabled.filter(untouched), 0u);
  EXPECT_TRUE(untouched[0].pose.isApprox(Eigen::Isometry3d::Identity()));
}

TEST(GripperVolume, AutomaticBackoffKeepsTheClosingLineBetweenTheFingers)
{
  // max_backoff_m = 0: half the finger depth minus 5 mm. Lacquey 0.09 m fingers: 0.04 m;
  // Robotiq 2F-85 0.04 m fingers: 0.015 m.
  EXPECT_NEAR(GripperVolumeCheck(lacquey(), GripperFitParams{}).maxBackoff(), 0.04, 1e-12);
  const GripperModel robotiq =
      loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/robotiq_2f85.yaml");
  EXPECT_NEAR(GripperVolumeCheck(robotiq, GripperFitParams{}).maxBackoff(), 0.015, 1e-12);
  GripperFitParams fixed;
  fixed.max_backoff_m = 0.02;
  EXPECT_NEAR(GripperVolumeCheck(robotiq, fixed).maxBackoff(), 0.02, 1e-12);
}

TEST(GripperVolume, InvalidParametersAreNamed)
{
  GripperFitParams params;
  params.max_backoff_m = -1.0;
  params.min_points_between_fingers = 0;
  const std::string why = params.validate();
  EXPECT_NE(why.find("max_backoff_m"), std::string::npos) << why;
  EXPECT_NE(why.find("min_points_between_fingers"), std::string::npos) << why;
  EXPECT_TRUE(GripperFitParams{}.validate().empty());
}

TEST(GripperVolume, PointsJustOutsideAnOpenFingerAreCountedAsGrazingIt)
{
  // Lacquey open 0.13: the +Y finger's inner face at y = 0.065. A block from y = -0.02 to
  // y = 0.062 is 3 mm inside that face: with a 4 mm graze margin its points at y >= 0.061
  // (the 0.062 column, 1 mm from the 0.065 - 0.004 limit) graze the finger, with 2 mm none.
  const GripperModel gripper = lacquey();
  const Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const CloudXYZ block = solidBox({ -0.01f, -0.02f, -0.004f }, { 0.01f, 0.062f, 0.004f });
  std::size_t near_face = 0;
  for (const auto& p : block.points)
    near_face += p.y >= 0.061f;
  ASSERT_GT(near_face, 0u);

  GripperFitParams params;
  params.finger_graze_margin_m = 0.004;
  GripperVolumeCheck check(gripper, params);
  check.addSeen(block);
  const GripperFit fit = check.fit(pose, 0.082);
  ASSERT_TRUE(fit.ok) << fit.why;  // grazing is counted, not a failure
  EXPECT_EQ(fit.points_grazing_fingers, near_face);

  params.finger_graze_margin_m = 0.002;
  GripperVolumeCheck looser(gripper, params);
  looser.addSeen(block);
  EXPECT_EQ(looser.fit(pose, 0.082).points_grazing_fingers, 0u);

  // Unseen-part points graze too; a margin of 0 counts nothing (the default).
  GripperVolumeCheck unseen_check(gripper, GripperFitParams{});
  unseen_check.addSeen(solidBox({ -0.01f, -0.02f, -0.004f }, { 0.01f, 0.02f, 0.004f }));
  unseen_check.addUnseen(block);
  EXPECT_EQ(unseen_check.fit(pose, 0.04).points_grazing_fingers, 0u);
  params.finger_graze_margin_m = 0.004;
  GripperVolumeCheck unseen_grazes(gripper, params);
  unseen_grazes.addSeen(solidBox({ -0.01f, -0.02f, -0.004f }, { 0.01f, 0.02f, 0.004f }));
  unseen_grazes.addUnseen(block);
  EXPECT_EQ(unseen_grazes.fit(pose, 0.04).points_grazing_fingers, near_face);

  params.finger_graze_margin_m = -0.001;
  EXPECT_NE(params.validate().find("finger_graze_margin_m"), std::string::npos);
}
