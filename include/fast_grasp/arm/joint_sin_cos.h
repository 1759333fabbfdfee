// Sine and cosine of a joint angle at once, inline, for forward kinematics in the planners'
// inner loop. ROS-free.
#pragma once

#include <cmath>

namespace fast_grasp
{
/// s = sin(angle_rad), c = cos(angle_rad), each within 1e-16 (absolute) of libm's for |angle| < 1e6 rad
/// (test_arm_kinematics compares them on a dense sweep). Why not std::sin / std::cos (or glibc's
/// sincos): those handle any double, with branches for huge arguments, and cost ~190
/// instructions a call; forward kinematics of every validity check calls it once per joint
/// (13 % of a UR5 check, callgrind). This reduces by pi/2 in three parts (Cody-Waite: exact
/// products with the first parts, so the remainder keeps full precision) and evaluates Cephes'
/// minimax polynomials for sin and cos on [-pi/4, pi/4], about 40 instructions for both.
/// Other arguments (|angle| >= 1e6, NaN, inf) go to libm.
inline void jointSinCos(double angle_rad, double& s, double& c)
{
  if (!(std::abs(angle_rad) < 1e6))
  {
    s = std::sin(angle_rad);
    c = std::cos(angle_rad);
    return;
  }
  // Quadrant: the multiple of pi/2 nearest the angle (truncation after adding +-0.5 rounds
  // half away from zero; an inline conversion, where std::lround is a library call).
  const double scaled = angle_rad * 0.63661977236758134308;  // 2 / pi
  const long quadrant = static_cast<long>(scaled + (scaled >= 0.0 ? 0.5 : -0.5));
  const double k = static_cast<double>(quadrant);
  // pi/2 = P1 + P2 + P3; P1 and P2 have short mantissas, so k * P1 and k * P2 are exact for
  // the k this is used for and the subtractions lose nothing.
  constexpr double kP1 = 1.57079625129699707031e+00;
  constexpr double kP2 = 7.54978941586159635335e-08;
  constexpr double kP3 = 5.39030285815811905290e-15;
  const double r = ((angle_rad - k * kP1) - k * kP2) - k * kP3;  // in [-pi/4, pi/4] (and a hair)
  const double z = r * r;
  const double sin_r =
      r + r * z *
              (-1.66666666666666307295e-01 +
               z * (8.33333333332211858878e-03 +
                    z * (-1.98412698295895385996e-04 +
                         z * (2.75573136213857245213e-06 + z * (-2.50507477628578072866e-08 + z * 1.58962301576546568060e-10)))));
  const double cos_r =
      1.0 - 0.5 * z +
      z * z *
          (4.16666666666665929218e-02 +
           z * (-1.38888888888730564116e-03 +
                z * (2.48015872888517045348e-05 +
                     z * (-2.75573141792967388112e-07 + z * (2.08757008419747316778e-09 + z * -1.13585365213876817300e-11)))));
  switch (quadrant & 3)  // two's complement: -1 & 3 == 3, the quadrant below 0
  {
    case 0:
      s = sin_r;
      c = cos_r;
      break;
    case 1:
      s = cos_r;
      c = -sin_r;
      break;
    case 2:
      s = -sin_r;
      c = -cos_r;
      break;
    default:
      s = -cos_r;
      c = sin_r;
      break;
  }
}

}  // namespace fast_grasp
