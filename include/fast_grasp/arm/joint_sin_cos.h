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
namespace sin_cos_detail
{
// pi/2 = kP1 + kP2 + kP3; kP1 and kP2 have short mantissas, so k * kP1 and k * kP2 are exact for
// the k this is used for and the subtractions lose nothing.
constexpr double kP1 = 1.57079625129699707031e+00;
constexpr double kP2 = 7.54978941586159635335e-08;
constexpr double kP3 = 5.39030285815811905290e-15;

// The reduction and the polynomials for a double or for GCC vector lanes of doubles
// (ArmKinematics::bodyFramesBatch): one text, so every lane does the scalar's operations in the
// scalar's order and gets its bits. Results through references: a function returning a 256-bit
// vector changes the ABI in code built without AVX (the batch's default clone; -Wpsabi).
/// r = the angle less k quarter turns: in [-pi/4, pi/4] (and a hair) for the nearest k.
template <typename T>
inline void reduceAngle(const T& angle_rad, const T& k, T& r)
{
  r = ((angle_rad - k * kP1) - k * kP2) - k * kP3;
}

/// sin and cos of a reduced angle r (z = r * r): Cephes' minimax polynomials.
template <typename T>
inline void sinOfReduced(const T& r, const T& z, T& sin_r)
{
  sin_r = r + r * z *
                 (-1.66666666666666307295e-01 +
                  z * (8.33333333332211858878e-03 +
                       z * (-1.98412698295895385996e-04 +
                            z * (2.75573136213857245213e-06 +
                                 z * (-2.50507477628578072866e-08 + z * 1.58962301576546568060e-10)))));
}
template <typename T>
inline void cosOfReduced(const T& z, T& cos_r)
{
  cos_r = 1.0 - 0.5 * z +
         z * z *
             (4.16666666666665929218e-02 +
              z * (-1.38888888888730564116e-03 +
                   z * (2.48015872888517045348e-05 +
                        z * (-2.75573141792967388112e-07 +
                             z * (2.08757008419747316778e-09 + z * -1.13585365213876817300e-11)))));
}

/// s, c of the angle from those of its remainder after `quadrant` quarter turns.
inline void rotateByQuadrant(long long quadrant, double sin_r, double cos_r, double& s, double& c)
{
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
}  // namespace sin_cos_detail

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
  double r = 0.0, sin_r = 0.0, cos_r = 1.0;
  sin_cos_detail::reduceAngle(angle_rad, static_cast<double>(quadrant), r);
  const double z = r * r;
  sin_cos_detail::sinOfReduced(r, z, sin_r);
  sin_cos_detail::cosOfReduced(z, cos_r);
  sin_cos_detail::rotateByQuadrant(quadrant, sin_r, cos_r, s, c);
}

}  // namespace fast_grasp
