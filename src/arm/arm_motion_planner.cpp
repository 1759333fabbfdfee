#include "fast_grasp/arm/arm_motion_planner.h"

#include "fast_grasp/arm/arm_rrt_connect.h"
#include "fast_grasp/arm/arm_motion_validator.h"
#include "fast_grasp/arm/batch_validity_checker.h"
#include "fast_grasp/arm/joint_nearest_neighbors.h"
#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/yaml_file.h"

#include <ompl/base/goals/GoalStates.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/base/spaces/SO2StateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/tools/config/MagicConstants.h>
#include <ompl/util/Console.h>
#include <ompl/geometric/planners/est/BiEST.h>
#include <ompl/geometric/planners/est/EST.h>
#include <ompl/geometric/planners/est/ProjEST.h>
#include <ompl/geometric/planners/fmt/BFMT.h>
#include <ompl/geometric/planners/fmt/FMT.h>
#include <ompl/geometric/planners/kpiece/BKPIECE1.h>
#include <ompl/geometric/planners/kpiece/KPIECE1.h>
#include <ompl/geometric/planners/kpiece/LBKPIECE1.h>
#include <ompl/geometric/planners/pdst/PDST.h>
#include <ompl/geometric/planners/prm/LazyPRM.h>
#include <ompl/geometric/planners/prm/LazyPRMstar.h>
#include <ompl/geometric/planners/prm/PRM.h>
#include <ompl/geometric/planners/prm/PRMstar.h>
#include <ompl/geometric/planners/prm/SPARS.h>
#include <ompl/geometric/planners/prm/SPARStwo.h>
#include <ompl/geometric/planners/rrt/BiTRRT.h>
#include <ompl/geometric/planners/rrt/LBTRRT.h>
#include <ompl/geometric/planners/rrt/RRT.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/geometric/planners/rrt/TRRT.h>
#include <ompl/geometric/planners/sbl/SBL.h>
#include <ompl/geometric/planners/stride/STRIDE.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <new>
#include <stdexcept>

namespace fast_grasp
{
namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace
{
/// The joint space: an SO2StateSpace per continuous joint (ArmKinematics::isContinuous), so
/// that distance, interpolation and sampling take the short way round it, and a
/// RealVectorStateSpace per run of bounded joints (one for an arm without continuous joints).
/// Distance is the Euclidean norm over the joints (OMPL's compound distance would sum the
/// components' distances); the motion validator's segment count also bounds the Cartesian
/// motion of every robot point (MotionPlanningParams::max_cartesian_step_m).
class ArmStateSpace : public ob::CompoundStateSpace
{
public:
  ArmStateSpace(const ArmKinematics& kin, Eigen::VectorXd lever_arms_m, double max_cartesian_step_m)
    : lever_arms_m_(std::move(lever_arms_m)), max_cartesian_step_m_(max_cartesian_step_m)
  {
    setName("ArmJoints");
    const std::size_t dof = kin.dof();
    for (std::size_t j = 0; j < dof;)
    {
      const unsigned component = static_cast<unsigned>(getSubspaceCount());
      if (kin.isContinuous(j))
      {
        addSubspace(std::make_shared<ob::SO2StateSpace>(), 1.0);
        component_dims_.push_back(0u);
        slots_.push_back({ component, 0u, true });
        ++j;
        continue;
      }
      std::size_t end = j;
      while (end < dof && !kin.isContinuous(end))
        ++end;
      auto bounded = std::make_shared<ob::RealVectorStateSpace>(static_cast<unsigned>(end - j));
      ob::RealVectorBounds bounds(static_cast<unsigned>(end - j));
      for (std::size_t k = j; k < end; ++k)
      {
        bounds.setLow(static_cast<unsigned>(k - j), kin.lowerLimits()[static_cast<Eigen::Index>(k)]);
        bounds.setHigh(static_cast<unsigned>(k - j), kin.upperLimits()[static_cast<Eigen::Index>(k)]);
        slots_.push_back({ component, static_cast<unsigned>(k - j), false });
      }
      bounded->setBounds(bounds);
      addSubspace(bounded, 1.0);
      component_dims_.push_back(static_cast<unsigned>(end - j));
      j = end;
    }
    lock();
    state_bytes_ = sizeof(ob::CompoundState) + componentCount_ * sizeof(ob::State*);
    for (const unsigned dims : component_dims_)
      state_bytes_ += dims == 0 ? sizeof(ob::SO2StateSpace::StateType) :
                                  sizeof(ob::RealVectorStateSpace::StateType) + dims * sizeof(double);
    // Every joint value sits at the same offset in every state's block (allocState).
    ob::State* probe = allocState();
    for (const Slot& slot : slots_)
    {
      ob::State* c = probe->as<ob::CompoundState>()->components[slot.component];
      const double* value = slot.continuous ? &c->as<ob::SO2StateSpace::StateType>()->value :
                                              &c->as<ob::RealVectorStateSpace::StateType>()->values[slot.index];
      joint_offsets_.push_back(static_cast<std::size_t>(reinterpret_cast<const char*>(value) -
                                                        reinterpret_cast<const char*>(probe)));
    }
    freeState(probe);
  }

  /// One allocation per state: the compound state, its component pointers, the components and
  /// their values in one block. OMPL's compound allocates each piece apart, and the nearest-
  /// neighbour queries' distance calls chase those pointers (RRTConnect on the LWR's shelf
  /// pick was ~8 % slower per tree state than on a flat RealVectorStateSpace; with the block
  /// and the fixed joint offsets below it costs the same).
  ob::State* allocState() const override
  {
    char* block = static_cast<char*>(::operator new(state_bytes_));
    auto* state = new (block) ob::CompoundState();
    state->components = reinterpret_cast<ob::State**>(block + sizeof(ob::CompoundState));
    std::size_t offset = sizeof(ob::CompoundState) + componentCount_ * sizeof(ob::State*);
    for (unsigned i = 0; i < componentCount_; ++i)
    {
      if (component_dims_[i] == 0)
      {
        state->components[i] = new (block + offset) ob::SO2StateSpace::StateType();
        offset += sizeof(ob::SO2StateSpace::StateType);
        continue;
      }
      auto* bounded = new (block + offset) ob::RealVectorStateSpace::StateType();
      offset += sizeof(ob::RealVectorStateSpace::StateType);
      bounded->values = reinterpret_cast<double*>(block + offset);
      offset += component_dims_[i] * sizeof(double);
      state->components[i] = bounded;
    }
    return state;
  }
  void freeState(ob::State* state) const override
  {
    auto* compound = static_cast<ob::CompoundState*>(state);
    for (unsigned i = 0; i < componentCount_; ++i)
    {
      if (component_dims_[i] == 0)
        compound->as<ob::SO2StateSpace::StateType>(i)->~StateType();
      else
        compound->as<ob::RealVectorStateSpace::StateType>(i)->~StateType();
    }
    compound->~CompoundState();
    ::operator delete(static_cast<void*>(compound));
  }

  /// OMPL's compound sampler scales a "near" distance (sampleUniformNear, sampleGaussian) by
  /// each component's share of the weights: a fifth per component for the JACO's five, so
  /// KPIECE, EST, SBL, BiEST, STRIDE ... would step each joint a fifth of what they step it
  /// on a single RealVectorStateSpace (BiEST then solved 7 % of the JACO's shelf picks). Every
  /// component gets the full distance here, as every joint does on the flat space.
  ob::StateSamplerPtr allocDefaultStateSampler() const override
  {
    auto sampler = std::make_shared<ob::CompoundStateSampler>(this);
    for (const ob::StateSpacePtr& component : components_)
      sampler->addSampler(component->allocStateSampler(), 1.0);
    return sampler;
  }

  std::size_t dof() const { return slots_.size(); }
  bool isContinuous(std::size_t j) const { return slots_[j].continuous; }
  /// Joint values of a state; continuous joints in (-pi, pi].
  void toJoints(const ob::State* state, double* q) const
  {
    for (std::size_t j = 0; j < joint_offsets_.size(); ++j)
      q[j] = joint(state, j);
  }
  /// Joint j's value: at a fixed offset in the state's block, no pointer to follow.
  double joint(const ob::State* state, std::size_t j) const
  {
    return *reinterpret_cast<const double*>(reinterpret_cast<const char*>(state) + joint_offsets_[j]);
  }
  Eigen::VectorXd toEigen(const ob::State* state) const
  {
    Eigen::VectorXd q(static_cast<Eigen::Index>(dof()));
    toJoints(state, q.data());
    return q;
  }
  /// Sets a state from joint values, continuous joints wrapped into (-pi, pi].
  void fromEigen(const Eigen::VectorXd& q, ob::State* state) const
  {
    auto* compound = state->as<ob::CompoundState>();
    for (std::size_t j = 0; j < slots_.size(); ++j)
    {
      const Slot& s = slots_[j];
      if (s.continuous)
      {
        compound->as<ob::SO2StateSpace::StateType>(s.component)->value = q[static_cast<Eigen::Index>(j)];
        components_[s.component]->enforceBounds(compound->components[s.component]);
      }
      else
        compound->as<ob::RealVectorStateSpace::StateType>(s.component)->values[s.index] = q[static_cast<Eigen::Index>(j)];
    }
  }
  /// Lower and upper bound of joint j (continuous: -pi, pi).
  std::pair<double, double> jointRange(std::size_t j) const
  {
    const Slot& s = slots_[j];
    if (s.continuous)
      return { -M_PI, M_PI };
    const ob::RealVectorBounds& b = components_[s.component]->as<ob::RealVectorStateSpace>()->getBounds();
    return { b.low[s.index], b.high[s.index] };
  }

  /// Euclidean over the joints, a continuous joint's difference taken the short way round
  /// (SO2StateSpace::distance), read at the joints' offsets in the state blocks: nearest-
  /// neighbour queries call this far more often than the validity checker (RRTConnect on the
  /// LWR's shelf pick: 40 % of solve time in GNAT and distance), and OMPL's compound distance
  /// follows three pointers and a virtual call per component.
  double distance(const ob::State* s1, const ob::State* s2) const override
  {
    double sum = 0.0;
    for (std::size_t j = 0; j < joint_offsets_.size(); ++j)
    {
      double d = std::abs(joint(s1, j) - joint(s2, j));
      if (slots_[j].continuous && d > M_PI)
        d = 2.0 * M_PI - d;
      sum += d * d;
    }
    return std::sqrt(sum);
  }
  double getMaximumExtent() const override
  {
    double sum = 0.0;
    for (const ob::StateSpacePtr& c : components_)
      sum += c->getMaximumExtent() * c->getMaximumExtent();
    return std::sqrt(sum);
  }
  /// The longest valid segment is a fraction of the whole space's extent (OMPL's and MoveIt's
  /// meaning of the fraction; the compound default would step each component by its own).
  unsigned int validSegmentCount(const ob::State* s1, const ob::State* s2) const override
  {
    const unsigned int by_fraction = ob::StateSpace::validSegmentCount(s1, s2);
    if (max_cartesian_step_m_ <= 0.0)
      return by_fraction;
    double sweep_m = 0.0;
    for (std::size_t j = 0; j < slots_.size(); ++j)
    {
      double d = std::abs(joint(s2, j) - joint(s1, j));
      if (slots_[j].continuous && d > M_PI)
        d = 2.0 * M_PI - d;
      sweep_m += d * lever_arms_m_[static_cast<Eigen::Index>(j)];
    }
    return std::max(by_fraction, static_cast<unsigned int>(std::ceil(sweep_m / max_cartesian_step_m_)));
  }

private:
  struct Slot
  {
    unsigned component;  // subspace index
    unsigned index;      // within a RealVectorStateSpace
    bool continuous;
  };
  std::vector<Slot> slots_;
  std::vector<unsigned> component_dims_;  // per subspace: 0 = SO2, else RealVector dimension
  std::size_t state_bytes_ = 0;
  std::vector<std::size_t> joint_offsets_;  // byte offset of each joint's value in a state block
  Eigen::VectorXd lever_arms_m_;
  double max_cartesian_step_m_;
};

/// Projection for the projection-based planners (KPIECE, SBL, EST, PDST, STRIDE): two joint
/// angles, cells a twentieth of each joint's range (OMPL's RealVectorOrthogonalProjection-
/// Evaluator on a compound space).
class JointPairProjection : public ob::ProjectionEvaluator
{
public:
  JointPairProjection(const ArmStateSpace* space, std::size_t first, std::size_t second)
    : ob::ProjectionEvaluator(space), arm_(space), joints_{ first, second }
  {
  }
  unsigned int getDimension() const override { return 2; }
  void defaultCellSizes() override
  {
    bounds_.resize(2);
    cellSizes_.resize(2);
    for (unsigned i = 0; i < 2; ++i)
    {
      const auto range = arm_->jointRange(joints_[i]);
      bounds_.low[i] = range.first;
      bounds_.high[i] = range.second;
      cellSizes_[i] = (range.second - range.first) / ompl::magic::PROJECTION_DIMENSION_SPLITS;
    }
  }
  void project(const ob::State* state, Eigen::Ref<Eigen::VectorXd> projection) const override
  {
    projection[0] = arm_->joint(state, joints_[0]);
    projection[1] = arm_->joint(state, joints_[1]);
  }

private:
  const ArmStateSpace* arm_;
  std::size_t joints_[2];
};

/// Thread-safe validity: everything is computed from the state (the only scratch is per
/// thread). No memory of verdicts: a table of them by the joint values' bits (ValidityCache,
/// session 17) saved instructions but cost time, its lookups missing the CPU caches (UR5
/// narrow passage -4 %, LWR shelf pick -10 %, end-to-end plan() -9 % CPU without it;
/// docs/benchmarks/arms.md, "Speed work, session 18"); its hits were mostly the benchmark's
/// own path checks.
class ArmValidityChecker : public BatchValidityChecker
{
public:
  ArmValidityChecker(const ob::SpaceInformationPtr& si, const ArmMotionPlanner& planner, MotionPlanningParams params)
    : BatchValidityChecker(si)
    , space_(si->getStateSpace()->as<ArmStateSpace>())
    , planner_(planner)
    , params_(std::move(params))
  {
  }
  bool isValid(const ob::State* state) const override
  {
    // Per-thread joint vector: this runs for every state a planner checks, and a heap
    // allocation per call showed up in the profile.
    thread_local Eigen::VectorXd q;
    q.resize(static_cast<Eigen::Index>(space_->dof()));
    space_->toJoints(state, q.data());
    return planner_.isValid(q, params_);
  }
  std::size_t firstInvalid(const ob::State* const* states, std::size_t count) const override
  {
    struct Scratch
    {
      std::vector<Eigen::VectorXd> qs;
      std::vector<const Eigen::VectorXd*> pointers;
    };
    thread_local Scratch scratch;
    Scratch& s = scratch;  // one thread-local lookup
    const auto dof = static_cast<Eigen::Index>(space_->dof());
    if (s.qs.size() < count)
    {
      s.qs.resize(count);
      s.pointers.resize(count);
    }
    for (std::size_t k = 0; k < count; ++k)
    {
      s.qs[k].resize(dof);
      space_->toJoints(states[k], s.qs[k].data());
      s.pointers[k] = &s.qs[k];
    }
    return planner_.firstInvalid(s.pointers.data(), count, params_);
  }

private:
  const ArmStateSpace* space_;
  const ArmMotionPlanner& planner_;
  const MotionPlanningParams params_;
};

/// Uniform sampling followed by a few damped Gauss-Newton steps that turn the grasp frame's
/// Z axis to the vertical. Without it, uniform joint samples satisfy a 0.1 rad tilt bound
/// about 0.5 % of the time (1 - cos 0.1 of the sphere); the validity checker still rejects
/// any state outside the bound, so this only makes the constrained search efficient.
class HorizontalGripperSampler : public ob::StateSampler
{
public:
  HorizontalGripperSampler(const ob::StateSpace* space, const ArmKinematics& kinematics, double tolerance_rad)
    : ob::StateSampler(space)
    , arm_(space->as<ArmStateSpace>())
    , base_(space->allocDefaultStateSampler())
    , kinematics_(kinematics)
    , tolerance_rad_(tolerance_rad)
  {
  }
  void sampleUniform(ob::State* state) override
  {
    base_->sampleUniform(state);
    project(state);
  }
  void sampleUniformNear(ob::State* state, const ob::State* near, double distance) override
  {
    base_->sampleUniformNear(state, near, distance);
    project(state);
  }
  void sampleGaussian(ob::State* state, const ob::State* mean, double stdDev) override
  {
    base_->sampleGaussian(state, mean, stdDev);
    project(state);
  }

private:
  void project(ob::State* state)
  {
    Eigen::VectorXd q = arm_->toEigen(state);
    for (int it = 0; it < 10; ++it)
    {
      const Eigen::Vector3d z = kinematics_.fk(q).linear().col(2);
      const Eigen::Vector3d up(0.0, 0.0, z.z() >= 0.0 ? 1.0 : -1.0);
      const double angle = std::acos(std::min(1.0, std::abs(z.z())));
      if (angle < 0.25 * tolerance_rad_)
        break;
      const Eigen::Vector3d w = z.cross(up).normalized() * angle;
      const Eigen::MatrixXd jw = kinematics_.jacobian(q).bottomRows(3);
      Eigen::Matrix3d jjt = jw * jw.transpose();
      jjt.diagonal().array() += 1e-4;
      q += jw.transpose() * jjt.ldlt().solve(w);
      kinematics_.wrapIntoLimits(q);
      q = q.cwiseMax(kinematics_.lowerLimits()).cwiseMin(kinematics_.upperLimits());
    }
    arm_->fromEigen(q, state);
  }

  const ArmStateSpace* arm_;
  ob::StateSamplerPtr base_;
  const ArmKinematics& kinematics_;
  double tolerance_rad_;
};

/// Our RRTConnect (ArmRRTConnect: OMPL's RRTConnect without its repeated checks and queries)
/// with its two trees in JointNearestNeighbors (exact, the same nearest states as OMPL's
/// default GNAT, several times cheaper per query at these trees' sizes: docs/benchmarks/arms.md,
/// "Speed work"). On a space other than ArmStateSpace the trees are OMPL's default.
ob::PlannerPtr makeRRTConnect(const ob::SpaceInformationPtr& si)
{
  const auto* arm = dynamic_cast<const ArmStateSpace*>(si->getStateSpace().get());
  if (!arm)
    return std::make_shared<ArmRRTConnect>(si);
  using Motion = ArmRRTConnect::Motion;
  std::vector<bool> continuous(arm->dof());
  for (std::size_t j = 0; j < continuous.size(); ++j)
    continuous[j] = arm->isContinuous(j);
  auto joints_of = [arm](Motion* const& motion, double* q) { arm->toJoints(motion->state, q); };
  return std::make_shared<ArmRRTConnect>(si, [continuous, joints_of]() {
    return std::make_shared<JointNearestNeighbors<Motion*>>(continuous, joints_of);
  });
}

template <typename PlannerT>
ob::PlannerPtr make(const ob::SpaceInformationPtr& si)
{
  return std::make_shared<PlannerT>(si);
}
}  // namespace

const char* toString(MotionPlanStatus status)
{
  switch (status)
  {
    case MotionPlanStatus::Success: return "success";
    case MotionPlanStatus::InvalidInput: return "invalid input";
    case MotionPlanStatus::UnknownPlanner: return "unknown planner";
    case MotionPlanStatus::StartInvalid: return "start state invalid";
    case MotionPlanStatus::GoalInvalid: return "goal state invalid";
    case MotionPlanStatus::NoPath: return "no path in time";
  }
  return "unknown";
}

ArmMotionPlanner::ArmMotionPlanner(const RobotCollision& collision) : collision_(collision)
{
  if (ompl::msg::getLogLevel() < ompl::msg::LOG_WARN)
    ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
}

const std::vector<std::string>& ArmMotionPlanner::plannerNames()
{
  static const std::vector<std::string> names = { "SBL",     "EST",         "BiEST", "ProjEST", "KPIECE",  "BKPIECE",
                                                  "LBKPIECE", "RRT",        "RRTConnect", "PDST", "STRIDE", "PRM",
                                                  "LazyPRM", "RRTstar",     "PRMstar", "LazyPRMstar", "FMT", "BFMT",
                                                  "LBTRRT",  "TRRT",        "BiTRRT", "SPARS", "SPARStwo" };
  return names;
}

ob::PlannerPtr ArmMotionPlanner::allocatePlanner(const std::string& name, const ob::SpaceInformationPtr& si,
                                                 const PlannerParameterTable& table,
                                                 std::vector<std::string>* unknown_params)
{
  using Factory = std::function<ob::PlannerPtr(const ob::SpaceInformationPtr&)>;
  static const std::map<std::string, Factory> factories = {
    { "SBL", make<og::SBL> },           { "EST", make<og::EST> },
    { "BiEST", make<og::BiEST> },       { "ProjEST", make<og::ProjEST> },
    { "KPIECE", make<og::KPIECE1> },    { "BKPIECE", make<og::BKPIECE1> },
    { "LBKPIECE", make<og::LBKPIECE1> }, { "RRT", make<og::RRT> },
    { "RRTConnect", makeRRTConnect }, { "PDST", make<og::PDST> },
    { "STRIDE", make<og::STRIDE> },     { "PRM", make<og::PRM> },
    { "LazyPRM", make<og::LazyPRM> },   { "RRTstar", make<og::RRTstar> },
    { "PRMstar", make<og::PRMstar> },   { "LazyPRMstar", make<og::LazyPRMstar> },
    { "FMT", make<og::FMT> },           { "BFMT", make<og::BFMT> },
    { "LBTRRT", make<og::LBTRRT> },     { "TRRT", make<og::TRRT> },
    { "BiTRRT", make<og::BiTRRT> },     { "SPARS", make<og::SPARS> },
    { "SPARStwo", make<og::SPARStwo> },
  };
  const auto factory = factories.find(name);
  if (factory == factories.end())
    return nullptr;
  ob::PlannerPtr planner = factory->second(si);
  const auto params = table.find(name);
  if (params != table.end())
  {
    for (const auto& kv : params->second)
    {
      if (!planner->params().hasParam(kv.first) || !planner->params().setParam(kv.first, kv.second))
      {
        if (unknown_params)
          unknown_params->push_back(name + "." + kv.first);
      }
    }
  }
  return planner;
}

double ArmMotionPlanner::gripperTiltRad(const Eigen::VectorXd& q) const
{
  const Eigen::Vector3d z = collision_.kinematics().fk(q).linear().col(2);
  return std::acos(std::min(1.0, std::abs(z.z())));
}

bool ArmMotionPlanner::isValid(const Eigen::VectorXd& q, const MotionPlanningParams& params, std::string* why) const
{
  const ArmKinematics& kin = collision_.kinematics();
  if (!kin.withinLimits(q, 1e-9))
  {
    if (why)
      *why = "outside the joint limits (or wrong size / NaN)";
    return false;
  }
  if (params.keep_gripper_horizontal && gripperTiltRad(q) > params.horizontal_tolerance_rad)
  {
    if (why)
      *why = "gripper not horizontal";
    return false;
  }
  return !collision_.inCollision(q, CollisionCheckOptions(), why);
}

std::size_t ArmMotionPlanner::firstInvalid(const Eigen::VectorXd* const* qs, std::size_t count,
                                           const MotionPlanningParams& params) const
{
  // isValid's joint-space tests state by state (cheap), then the collision tests of the states
  // before the first that fails them, together; firstInCollision answers `limit` when those
  // are all clear.
  const ArmKinematics& kin = collision_.kinematics();
  std::size_t limit = count;
  for (std::size_t k = 0; k < count && limit == count; ++k)
    if (!kin.withinLimits(*qs[k], 1e-9) ||
        (params.keep_gripper_horizontal && gripperTiltRad(*qs[k]) > params.horizontal_tolerance_rad))
      limit = k;
  return collision_.firstInCollision(qs, limit, CollisionCheckOptions());
}

std::shared_ptr<og::SimpleSetup> ArmMotionPlanner::makeSetup(const Eigen::VectorXd& start,
                                                             const std::vector<Eigen::VectorXd>& goals,
                                                             const MotionPlanningParams& params) const
{
  const ArmKinematics& kin = collision_.kinematics();
  const std::size_t dof = kin.dof();
  auto space = std::make_shared<ArmStateSpace>(kin, collision_.jointLeverArms(), params.max_cartesian_step_m);
  // The two proximal joints move the arm most (MoveIt's default projection too).
  space->registerDefaultProjection(
      std::make_shared<JointPairProjection>(space.get(), 0u, std::min<std::size_t>(1u, dof - 1)));
  if (params.keep_gripper_horizontal)
  {
    const ArmKinematics* kin_ptr = &kin;
    const double tol = params.horizontal_tolerance_rad;
    space->setStateSamplerAllocator([kin_ptr, tol](const ob::StateSpace* s) -> ob::StateSamplerPtr {
      return std::make_shared<HorizontalGripperSampler>(s, *kin_ptr, tol);
    });
  }
  auto setup = std::make_shared<og::SimpleSetup>(space);
  setup->setStateValidityChecker(
      std::make_shared<ArmValidityChecker>(setup->getSpaceInformation(), *this, params));
  setup->getSpaceInformation()->setStateValidityCheckingResolution(params.longest_valid_segment_fraction);
  // OMPL's discrete motion checks, a motion's states handed to the checker together.
  setup->getSpaceInformation()->setMotionValidator(std::make_shared<ArmMotionValidator>(setup->getSpaceInformation()));
  ob::ScopedState<> start_state(space);
  space->fromEigen(start, start_state.get());
  setup->setStartState(start_state);
  auto goal_states = std::make_shared<ob::GoalStates>(setup->getSpaceInformation());
  for (const Eigen::VectorXd& g : goals)
  {
    ob::ScopedState<> goal_state(space);
    space->fromEigen(g, goal_state.get());
    goal_states->addState(goal_state);
  }
  setup->setGoal(goal_states);
  return setup;
}

MotionPlanResult ArmMotionPlanner::plan(const Eigen::VectorXd& start, const std::vector<Eigen::VectorXd>& goals,
                                        const MotionPlanningParams& params) const
{
  const Stopwatch clock;
  MotionPlanResult result;
  const std::size_t dof = collision_.kinematics().dof();
  if (start.size() != static_cast<Eigen::Index>(dof) || !start.allFinite() || goals.empty())
  {
    result.message = "start must have " + std::to_string(dof) + " finite joints and at least one goal is needed";
    return result;
  }
  const auto& names = plannerNames();
  if (std::find(names.begin(), names.end(), params.planner) == names.end())
  {
    result.status = MotionPlanStatus::UnknownPlanner;
    result.message = "unknown planner '" + params.planner + "'";
    return result;
  }
  std::string why;
  if (!isValid(start, params, &why))
  {
    result.status = MotionPlanStatus::StartInvalid;
    result.message = "start state invalid: " + why;
    return result;
  }
  std::vector<Eigen::VectorXd> valid_goals;
  for (const Eigen::VectorXd& g : goals)
    if (g.size() == static_cast<Eigen::Index>(dof) && isValid(g, params, &why))
      valid_goals.push_back(g);
  if (valid_goals.empty())
  {
    result.status = MotionPlanStatus::GoalInvalid;
    result.message = "every goal state is invalid (last: " + why + ")";
    return result;
  }

  // Lazy validation: the planner runs with the thesis's coarse motion check (fast), then every
  // segment of its path is checked with the sound validator (no robot point moves more than
  // max_cartesian_step_m between checks); a failing segment is re-planned locally with the
  // sound validator, which is quick because its ends are valid and close. A path that cannot
  // be repaired is dropped and the planner runs again within the budget.
  MotionPlanningParams coarse = params;
  if (params.lazy_validation)
    coarse.max_cartesian_step_m = 0.0;
  const std::shared_ptr<og::SimpleSetup> sound = makeSetup(start, valid_goals, params);
  sound->setPlanner(allocatePlanner("RRTConnect", sound->getSpaceInformation(), params.planner_params));
  sound->setup();
  const ob::SpaceInformationPtr sound_si = sound->getSpaceInformation();
  const std::shared_ptr<og::SimpleSetup> setup = params.lazy_validation ? makeSetup(start, valid_goals, coarse) : sound;
  ob::PlannerPtr planner = allocatePlanner(params.planner, setup->getSpaceInformation(), params.planner_params);
  setup->setPlanner(planner);
  setup->setup();

  auto remaining = [&]() { return params.planning_time_s - clock.elapsedSeconds(); };
  const ArmStateSpace* space = setup->getStateSpace()->as<ArmStateSpace>();
  auto toEigen = [space](const ob::State* state) { return space->toEigen(state); };
  // Returns the repaired path, or an empty one.
  auto repair = [&](const og::PathGeometric& path) {
    std::vector<Eigen::VectorXd> out;
    out.push_back(toEigen(path.getState(0)));
    for (std::size_t k = 0; k + 1 < path.getStateCount(); ++k)
    {
      const ob::State* a = path.getState(k);
      const ob::State* b = path.getState(k + 1);
      if (sound_si->checkMotion(a, b))
      {
        out.push_back(toEigen(b));
        continue;
      }
      ++result.repaired_segments;
      const std::shared_ptr<og::SimpleSetup> local =
          makeSetup(toEigen(a), { toEigen(b) }, params);
      local->setPlanner(allocatePlanner("RRTConnect", local->getSpaceInformation(), params.planner_params));
      local->setup();
      if (remaining() <= 0.0 || local->solve(remaining()) != ob::PlannerStatus::EXACT_SOLUTION)
        return std::vector<Eigen::VectorXd>();
      local->simplifySolution(std::max(0.005, std::min(0.05, remaining())));
      const og::PathGeometric& detour = local->getSolutionPath();
      for (std::size_t i = 1; i < detour.getStateCount(); ++i)
        out.push_back(toEigen(detour.getState(i)));
    }
    return out;
  };
  int rejected_paths = 0;
  while (true)
  {
    const ob::PlannerStatus status =
        remaining() > 0.0 ? setup->solve(remaining()) : ob::PlannerStatus(ob::PlannerStatus::TIMEOUT);
    if (status != ob::PlannerStatus::EXACT_SOLUTION || !setup->haveExactSolutionPath())
    {
      result.status = MotionPlanStatus::NoPath;
      result.message = std::string("no exact path within ") + std::to_string(params.planning_time_s) + " s (" +
                       status.asString() +
                       (rejected_paths ? ", " + std::to_string(rejected_paths) + " paths could not be repaired" :
                                         std::string()) +
                       ")";
      result.planning_time_s = clock.elapsedSeconds();
      return result;
    }
    if (params.simplify)
      setup->simplifySolution(std::max(0.01, std::min(params.simplify_time_s, std::max(0.0, remaining()))));
    result.path = params.lazy_validation ? repair(setup->getSolutionPath()) : std::vector<Eigen::VectorXd>();
    if (!params.lazy_validation)
    {
      const og::PathGeometric& path = setup->getSolutionPath();
      for (std::size_t k = 0; k < path.getStateCount(); ++k)
        result.path.push_back(toEigen(path.getState(k)));
    }
    if (!result.path.empty())
      break;
    ++rejected_paths;
    setup->clear();  // drop the planner's data and the rejected solution, then try again
  }
  // The states hold continuous joints in (-pi, pi]: the path starts at the start as given and
  // each waypoint takes the equivalent angle nearest the previous one, so the path turns the
  // short way OMPL interpolated and never jumps by 2 pi (it may leave (-pi, pi]).
  const ArmKinematics& kin = collision_.kinematics();
  result.path.front() = start;
  for (std::size_t k = 1; k < result.path.size(); ++k)
    result.path[k] = kin.nearestEquivalent(result.path[k], result.path[k - 1]);
  result.path_length_rad = 0.0;
  for (std::size_t k = 1; k < result.path.size(); ++k)
    result.path_length_rad += (result.path[k] - result.path[k - 1]).norm();
  result.planning_time_s = clock.elapsedSeconds();
  result.status = MotionPlanStatus::Success;
  result.message = params.planner + ": " + std::to_string(result.path.size()) + " waypoints";
  return result;
}

PlannerParameterTable loadPlannerParameters(const std::string& yaml_path)
{
  YAML::Node root;
  try
  {
    root = loadYamlFile(yaml_path);
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error("planner parameters '" + yaml_path + "': " + e.what());
  }
  PlannerParameterTable table;
  if (!root.IsMap())
    throw std::runtime_error("planner parameters '" + yaml_path + "': expected a map of planner names");
  for (const auto& planner : root)
  {
    const std::string name = planner.first.as<std::string>();
    auto& entry = table[name];
    if (planner.second.IsNull())
      continue;
    if (!planner.second.IsMap())
      throw std::runtime_error("planner parameters '" + yaml_path + "': entry '" + name + "' is not a map");
    for (const auto& kv : planner.second)
      entry[kv.first.as<std::string>()] = kv.second.as<std::string>();
  }
  return table;
}

}  // namespace fast_grasp
