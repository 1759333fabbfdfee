// fast_grasp::Grasp <-> fast_grasp/Grasp.msg. Header-only: used by nodelets and tools.
#pragma once

#include "fast_grasp/Grasp.h"
#include "fast_grasp/GraspArray.h"
#include "fast_grasp/core/grasp_types.h"

#include <tf2_eigen/tf2_eigen.h>

namespace fast_grasp
{
inline geometry_msgs::Vector3 toVector3Msg(const Eigen::Vector3d& v)
{
  geometry_msgs::Vector3 msg;
  msg.x = v.x();
  msg.y = v.y();
  msg.z = v.z();
  return msg;
}

inline fast_grasp::Grasp toMsg(const GraspCandidate& grasp)
{
  fast_grasp::Grasp msg;
  msg.pose = tf2::toMsg(grasp.pose);
  msg.position = msg.pose.position;
  msg.approach = toVector3Msg(grasp.approach());
  msg.binormal = toVector3Msg(grasp.binormal());
  msg.axis = toVector3Msg(grasp.axis());
  msg.width_m = grasp.width_m;
  msg.score = grasp.score;
  msg.force_balance_rad = grasp.force_balance_rad;
  msg.xoz_offset_m = grasp.xoz_offset_m;
  msg.variance_m = grasp.variance_m;
  msg.torque_offset_m = grasp.torque_offset_m;
  msg.gravity_offset_m = grasp.gravity_offset_m;
  msg.algorithm = grasp.algorithm;
  return msg;
}

inline GraspCandidate fromMsg(const fast_grasp::Grasp& msg)
{
  GraspCandidate grasp;
  tf2::fromMsg(msg.pose, grasp.pose);
  grasp.width_m = msg.width_m;
  grasp.score = msg.score;
  grasp.force_balance_rad = msg.force_balance_rad;
  grasp.xoz_offset_m = msg.xoz_offset_m;
  grasp.variance_m = msg.variance_m;
  grasp.torque_offset_m = msg.torque_offset_m;
  grasp.gravity_offset_m = msg.gravity_offset_m;
  grasp.algorithm = msg.algorithm;
  return grasp;
}

/// "ok" on success, else "<FailureType>: <reason>".
inline std::string statusText(const GraspResult& result)
{
  if (result.ok())
    return "ok";
  return std::string(toString(result.failure == GraspFailure::None ? GraspFailure::NoStableGrasp : result.failure)) +
         ": " + result.message;
}

inline fast_grasp::GraspArray toMsg(const GraspResult& result, const std_msgs::Header& header)
{
  fast_grasp::GraspArray msg;
  msg.header = header;
  msg.grasps.reserve(result.grasps.size());
  for (const auto& grasp : result.grasps)
    msg.grasps.push_back(toMsg(grasp));
  msg.compute_time_s = result.compute_time_s;
  msg.status = statusText(result);
  return msg;
}

}  // namespace fast_grasp
