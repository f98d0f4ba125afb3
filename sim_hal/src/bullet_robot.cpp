// The Bullet backend. The robot is a btMultiBody built from springbok::robot:
// every Bullet link lives in a frame at its body's COM whose axes are the
// principal axes of inertia (Bullet assumes a diagonal inertia), so each body
// carries the transform between that frame and the model's body frame.
#include "springbok/sim_hal/bullet_robot.hpp"

#include <BulletCollision/CollisionShapes/btBoxShape.h>
#include <BulletCollision/CollisionShapes/btCompoundShape.h>
#include <BulletCollision/CollisionShapes/btCylinderShape.h>
#include <BulletCollision/CollisionShapes/btSphereShape.h>
#include <BulletCollision/CollisionShapes/btStaticPlaneShape.h>
#include <BulletCollision/NarrowPhaseCollision/btPersistentManifold.h>
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>
#include <BulletCollision/CollisionDispatch/btDefaultCollisionConfiguration.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyJointLimitConstraint.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "springbok/sim_hal/principal_inertia.hpp"

namespace springbok::sim {
namespace {

static_assert(sizeof(btScalar) == sizeof(double), "springbok needs Bullet's double-precision build");

constexpr int kRobotGroup = 1 << 1;
constexpr int kGroundGroup = 1 << 2;
// Bullet clamps every generalized velocity to this; ours never get near it.
constexpr double kMaxCoordinateVelocity = 1.0e4;
constexpr double kMaxAppliedImpulse = 1.0e6;
// Box and cylinder shapes keep their outer size; the margin only rounds edges.
constexpr double kShapeMargin_m = 1.0e-3;

btVector3 to_bt(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
Vec3 to_eigen(const btVector3& v) { return {v.x(), v.y(), v.z()}; }

btMatrix3x3 to_bt(const Mat3& m) {
  return {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
}
Mat3 to_eigen(const btMatrix3x3& m) {
  Mat3 out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = m[r][c];
  return out;
}
// The quaternion q with quatRotate(q, x) == m x.
btQuaternion to_bt_quaternion(const Mat3& m) {
  btQuaternion q;
  to_bt(m).getRotation(q);
  return q;
}

Mat3 rotation_of(const model::Transform& t) {
  Mat3 r;
  r << t.rotation[0], t.rotation[1], t.rotation[2], t.rotation[3], t.rotation[4], t.rotation[5], t.rotation[6],
      t.rotation[7], t.rotation[8];
  return r;
}
Vec3 translation_of(const model::Transform& t) { return {t.translation[0], t.translation[1], t.translation[2]}; }
Eigen::Isometry3d isometry_of(const model::Transform& t) {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = rotation_of(t);
  iso.translation() = translation_of(t);
  return iso;
}
Eigen::Isometry3d isometry_of(const btTransform& t) {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = to_eigen(t.getBasis());
  iso.translation() = to_eigen(t.getOrigin());
  return iso;
}
btTransform to_bt(const Eigen::Isometry3d& iso) { return btTransform(to_bt(Mat3(iso.linear())), to_bt(Vec3(iso.translation()))); }

bool all_finite(const auto& m) { return m.allFinite(); }

// Whether joint `link` may reach a stop within the step: within 0.02 rad of one, or of its
// reach at twice its speed.
bool near_joint_limit(const btMultiBody& body, int link, double lower_rad, double upper_rad, double dt_s) {
  constexpr double kLimitMargin_rad = 0.02;
  const double q = body.getJointPos(link);
  const double margin_rad = kLimitMargin_rad + 2.0 * std::abs(body.getJointVel(link)) * dt_s;
  return q - lower_rad <= margin_rad || upper_rad - q <= margin_rad;
}

// Bullet's joint limit, but its two solver rows exist only while the joint is
// near a limit: far from both it cannot reach one within the step, and the
// rows (each an articulated-body pass in the solver) were most of the cost.
class NearJointLimit final : public btMultiBodyJointLimitConstraint {
 public:
  NearJointLimit(btMultiBody* body, int link, double lower_rad, double upper_rad)
      : btMultiBodyJointLimitConstraint(body, link, lower_rad, upper_rad) {}

  void createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                            const btContactSolverInfo& info) override {
    if (!near(info.m_timeStep)) return;
    btMultiBodyJointLimitConstraint::createConstraintRows(rows, data, info);
  }
  bool near(double dt_s) const { return near_joint_limit(*m_bodyA, m_linkA, m_lowerBound, m_upperBound, dt_s); }
};

// The ground plane z = 0, but with a bounding box that is a slab from 1 m
// under the plane to Bullet's contact breaking threshold above it rather than
// all of space: the broadphase then pairs only the links near the ground (the
// feet, while standing) and the narrowphase skips every other link (most of
// the collision cost was links far above the ground tested against the plane).
// The slab reaches up by the threshold so that a foot hovering just above the
// ground keeps its (speculative) contact point as with an unbounded plane.
class GroundPlane final : public btStaticPlaneShape {
 public:
  GroundPlane() : btStaticPlaneShape(btVector3(0.0, 0.0, 1.0), 0.0) {}
  void getAabb(const btTransform& t, btVector3& aabb_min, btVector3& aabb_max) const override {
    aabb_min = t.getOrigin() + btVector3(-kHalfExtent_m, -kHalfExtent_m, -kDepth_m);
    aabb_max = t.getOrigin() + btVector3(kHalfExtent_m, kHalfExtent_m, gContactBreakingThreshold);
  }

 private:
  static constexpr double kHalfExtent_m = 1.0e6;
  static constexpr double kDepth_m = 1.0;
};

// Bullet's multibody world, without the prediction of the link poses at the
// end of the step: only continuous collision detection of rigid bodies reads
// them, and this world has no rigid bodies (identical results, ~3% less work).
class RobotWorld final : public btMultiBodyDynamicsWorld {
 public:
  using btMultiBodyDynamicsWorld::btMultiBodyDynamicsWorld;

 protected:
  void predictUnconstraintMotion(btScalar /*time_step_s*/) override {}
};

std::string check_config(const SimConfig& c) {
  if (!(std::isfinite(c.step_s) && c.step_s > 0.0)) return "step_s must be finite and > 0";
  if (c.substeps < 1) return "substeps must be >= 1";
  if (c.solver_iterations < 1) return "solver_iterations must be >= 1";
  if (c.limit_solver_iterations < 1) return "limit_solver_iterations must be >= 1";
  if (!std::isfinite(c.gravity_m_s2)) return "gravity_m_s2 must be finite";
  if (!(std::isfinite(c.ground_friction) && c.ground_friction >= 0.0)) return "ground_friction must be finite and >= 0";
  if (!(std::isfinite(c.ground_restitution) && c.ground_restitution >= 0.0 && c.ground_restitution <= 1.0))
    return "ground_restitution must be in [0, 1]";
  const auto& n = c.imu;
  for (double s : {n.gyro_noise_rad_s, n.accel_noise_m_s2, n.gyro_bias_rad_s, n.accel_bias_m_s2}) {
    if (!(std::isfinite(s) && s >= 0.0)) return "imu noise and bias must be finite and >= 0";
  }
  if (c.imu.active() && !is_ideal(c.sensors.imu)) {
    return "imu (the legacy ImuNoise) and sensors.imu are both set: give the IMU's model in one of them";
  }
  if (std::string why = check_sensor_model(c.sensors, c.step_s); !why.empty()) return "sensors." + why;
  for (int t : {c.latency.joint_measurement_ticks, c.latency.sensor_measurement_ticks, c.latency.command_ticks}) {
    if (t < 0 || t > Latency::kMaxTicks) return "latency ticks must be in [0, 4]";
  }
  if (!all_finite(c.initial_q)) return "initial_q must be finite";
  if (c.initial_q.segment<4>(3).norm() < 0.5) return "initial_q: the base quaternion is far from unit norm";
  if (!all_finite(c.initial_v)) return "initial_v must be finite";
  return {};
}

}  // namespace

struct BulletRobot::Impl {
  explicit Impl(const SimConfig& c) : config(c) {}
  ~Impl() { teardown(); }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  SimConfig config;
  double substep_s = 0.0;

  // ---- Bullet objects (owned here; removed from the world before deletion) ----
  std::unique_ptr<btDefaultCollisionConfiguration> collision_config;
  std::unique_ptr<btCollisionDispatcher> dispatcher;
  std::unique_ptr<btDbvtBroadphase> broadphase;
  std::unique_ptr<btMultiBodyConstraintSolver> solver;
  std::unique_ptr<RobotWorld> world;
  std::unique_ptr<btMultiBody> body;
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::array<std::unique_ptr<btMultiBodyLinkCollider>, kNb> colliders;
  std::vector<std::unique_ptr<NearJointLimit>> limits;
  std::unique_ptr<GroundPlane> ground_shape;
  std::unique_ptr<btCollisionObject> ground;
  btAlignedObjectArray<btQuaternion> scratch_rotations;
  btAlignedObjectArray<btVector3> scratch_origins;

  // Per body: the Bullet (principal COM) frame in the model's body frame, and its inverse.
  std::array<Eigen::Isometry3d, kNb> body_from_com{};
  std::array<Eigen::Isometry3d, kNb> com_from_body{};
  // Per foot: the body carrying it and the index of its sphere in that body's compound.
  std::array<int, kFeet> foot_body{};
  std::array<int, kFeet> foot_child{};

  // ---- run-time state ----
  bool configured = false;
  bool active = false;
  std::int64_t tick = 0;
  std::int64_t sample_tick = 0;  // the sensors' samples: tick plus the ticks held still
  std::uint64_t read_sequence = 0;
  hal::JointCommands command;  // the last write()
  hal::JointCommands applied;  // what the drives apply in this step (command, `command_ticks` ago)
  // The last kMaxTicks + 1 ticks, by tick modulo the size (Latency).
  struct Sampled {
    VecNj q_rad = VecNj::Zero(), qd_rad_s = VecNj::Zero(), tau_nm = VecNj::Zero();
    hal::Imu imu;
    hal::Wrench wrist;
  };
  static constexpr int kHistory = Latency::kMaxTicks + 1;
  std::array<Sampled, kHistory> sampled{};
  std::array<hal::JointCommands, kHistory> written{};
  static std::size_t slot(std::int64_t tick, int ago) noexcept {
    return static_cast<std::size_t>(((tick - ago) % kHistory + kHistory) % kHistory);
  }
  std::array<ExternalWrench, kMaxExternalWrenches> wrenches{};
  int wrench_count = 0;
  GroundTruth truth;
  hal::Imu imu;
  hal::Wrench wrist;
  Vec3 previous_imu_velocity_world = Vec3::Zero();
  SensorModel sensors;

  void teardown() noexcept {
    if (!world) return;
    for (auto& limit : limits) world->removeMultiBodyConstraint(limit.get());
    for (auto& collider : colliders) {
      if (collider) world->removeCollisionObject(collider.get());
    }
    if (body) world->removeMultiBody(body.get());
    if (ground) world->removeCollisionObject(ground.get());
  }

  std::string build();
  void add_colliders();
  void update_kinematics() noexcept {
    body->forwardKinematics(scratch_rotations, scratch_origins);
    body->updateCollisionObjectWorldTransforms(scratch_rotations, scratch_origins);
  }
  Eigen::Isometry3d com_pose(int b) const noexcept {
    if (b == 0) return isometry_of(body->getBaseWorldTransform());
    return isometry_of(colliders[b]->getWorldTransform());
  }
  Eigen::Isometry3d body_pose(int b) const noexcept { return com_pose(b) * com_from_body[b]; }
  void set_state(const VecNq& q, const VecNv& v) noexcept;
  void read_state(VecNq& q, VecNv& v) const noexcept;
  void apply_drive_torques() noexcept;
  void apply_external_wrenches(double t_s) noexcept;
  void accumulate_contacts(double weight) noexcept;
  void update_sensors(bool first) noexcept;
};

std::string BulletRobot::Impl::build() {
  substep_s = config.step_s / config.substeps;
  collision_config = std::make_unique<btDefaultCollisionConfiguration>();
  dispatcher = std::make_unique<btCollisionDispatcher>(collision_config.get());
  broadphase = std::make_unique<btDbvtBroadphase>();
  solver = std::make_unique<btMultiBodyConstraintSolver>();
  world = std::make_unique<RobotWorld>(dispatcher.get(), broadphase.get(), solver.get(), collision_config.get());
  world->setGravity(btVector3(0.0, 0.0, -config.gravity_m_s2));
  auto& info = world->getSolverInfo();
  info.m_numIterations = config.solver_iterations;
  // Two friction directions from the contact normal alone: isotropic and
  // independent of the sliding velocity (deterministic).
  info.m_solverMode |= SOLVER_USE_2_FRICTION_DIRECTIONS | SOLVER_DISABLE_VELOCITY_DEPENDENT_FRICTION_DIRECTION;
  info.m_solverMode &= ~SOLVER_RANDMIZE_ORDER;
  world->getDispatchInfo().m_deterministicOverlappingPairs = true;

  // ---- the tree ----
  std::array<PrincipalInertia, kNb> principal{};
  for (int b = 0; b < kNb; ++b) {
    principal[b] = principal_inertia(springbok::body_inertia(b, config.rotors));  // as the controller's model
    body_from_com[b] = Eigen::Isometry3d::Identity();
    body_from_com[b].linear() = principal[b].rotation;
    body_from_com[b].translation() = principal[b].com_m;
    com_from_body[b] = body_from_com[b].inverse();
  }
  body = std::make_unique<btMultiBody>(kNj, robot::kBaseInertia.mass_kg, to_bt(principal[0].moments_kgm2),
                                       config.fixed_base, /*canSleep=*/false);
  for (int j = 0; j < kNj; ++j) {
    const auto& joint = robot::kJoints[j];
    const int child = j + 1;
    const int parent = joint.parent_body;
    const Mat3& parent_axes = principal[parent].rotation;
    const Mat3& child_axes = principal[child].rotation;
    const Mat3 joint_rotation = rotation_of(joint.origin);
    const Vec3 axis(joint.axis[0], joint.axis[1], joint.axis[2]);
    // Coordinates: parent COM frame -> child COM frame at q = 0.
    const Mat3 parent_to_child = child_axes.transpose() * joint_rotation.transpose() * parent_axes;
    const Vec3 parent_com_to_pivot = parent_axes.transpose() * (translation_of(joint.origin) - principal[parent].com_m);
    const Vec3 pivot_to_child_com = child_axes.transpose() * principal[child].com_m;
    body->setupRevolute(j, joint.inertia.mass_kg, to_bt(principal[child].moments_kgm2), parent - 1,
                        to_bt_quaternion(parent_to_child), to_bt(Vec3(child_axes.transpose() * axis)),
                        to_bt(parent_com_to_pivot), to_bt(pivot_to_child_com), /*disableParentCollision=*/true);
  }
  body->finalizeMultiDof();
  // The settings that matter for a torque-controlled robot at 1 kHz.
  body->setCanSleep(false);
  body->setLinearDamping(0.0);
  body->setAngularDamping(0.0);
  body->setUseGyroTerm(true);
  body->setMaxCoordinateVelocity(kMaxCoordinateVelocity);
  body->setMaxAppliedImpulse(kMaxAppliedImpulse);
  body->setHasSelfCollision(false);
  world->addMultiBody(body.get(), kRobotGroup, kGroundGroup);

  add_colliders();
  for (int f = 0; f < kFeet; ++f) {
    if (foot_child[f] < 0) return "the model has no foot sphere on body " + std::to_string(foot_body[f]);
  }

  for (int j = 0; j < kNj; ++j) {
    const auto& limits_j = robot::kJoints[j].limits;
    if (!limits_j.bounded) continue;
    auto limit = std::make_unique<NearJointLimit>(body.get(), j, limits_j.lower_rad, limits_j.upper_rad);
    limit->setMaxAppliedImpulse(kMaxAppliedImpulse);
    world->addMultiBodyConstraint(limit.get());
    limits.push_back(std::move(limit));
  }

  if (config.ground) {
    ground_shape = std::make_unique<GroundPlane>();
    ground = std::make_unique<btCollisionObject>();
    ground->setCollisionShape(ground_shape.get());
    // Bullet multiplies the two bodies' coefficients; the robot's are 1.
    ground->setFriction(config.ground_friction);
    ground->setRestitution(config.ground_restitution);
    world->addCollisionObject(ground.get(), kGroundGroup, kRobotGroup);
  }

  // The sensor model, with the legacy ImuNoise mapped onto its IMU; the IMU's stream keeps the
  // legacy seed unless sensors.imu is in use (check_config refused both at once).
  SensorModelConfig model = config.sensors;
  const auto& legacy = config.imu;
  if (legacy.active()) {
    apply_legacy_imu(legacy.gyro_noise_rad_s, legacy.accel_noise_m_s2, legacy.gyro_bias_rad_s, legacy.accel_bias_m_s2,
                     config.step_s, model.imu);
  }
  const std::uint64_t imu_seed = is_ideal(config.sensors.imu) ? legacy.seed : config.sensors.seed;
  if (std::string why = sensors.configure(model, config.step_s, imu_seed); !why.empty()) return "sensors." + why;
  return {};
}

void BulletRobot::Impl::add_colliders() {
  std::array<btCompoundShape*, kNb> compounds{};
  for (int b = 0; b < kNb; ++b) {
    auto compound = std::make_unique<btCompoundShape>(/*enableDynamicAabbTree=*/false);
    compounds[b] = compound.get();
    shapes.push_back(std::move(compound));
  }
  for (int f = 0; f < kFeet; ++f) {
    foot_body[f] = robot::kFrames[kFootFrames[f]].body;
    foot_child[f] = -1;
  }
  for (const auto& c : robot::kCollisions) {
    std::unique_ptr<btCollisionShape> shape;
    switch (c.shape) {
      case model::Shape::box:
        shape = std::make_unique<btBoxShape>(btVector3(0.5 * c.size_m[0], 0.5 * c.size_m[1], 0.5 * c.size_m[2]));
        break;
      case model::Shape::cylinder:
        shape = std::make_unique<btCylinderShapeZ>(btVector3(c.size_m[0], c.size_m[0], 0.5 * c.size_m[1]));
        break;
      case model::Shape::sphere:
        shape = std::make_unique<btSphereShape>(c.size_m[0]);
        break;
    }
    if (c.shape != model::Shape::sphere) shape->setMargin(kShapeMargin_m);
    const btTransform in_com = to_bt(com_from_body[c.body] * isometry_of(c.origin));
    if (c.shape == model::Shape::sphere) {
      for (int f = 0; f < kFeet; ++f) {
        if (foot_body[f] == c.body) foot_child[f] = compounds[c.body]->getNumChildShapes();
      }
    }
    compounds[c.body]->addChildShape(in_com, shape.get());
    shapes.push_back(std::move(shape));
  }
  for (int b = 0; b < kNb; ++b) {
    auto collider = std::make_unique<btMultiBodyLinkCollider>(body.get(), b - 1);
    collider->setCollisionShape(compounds[b]);
    collider->setFriction(1.0);
    collider->setRestitution(1.0);
    world->addCollisionObject(collider.get(), kRobotGroup, kGroundGroup);
    if (b == 0) {
      body->setBaseCollider(collider.get());
    } else {
      body->getLink(b - 1).m_collider = collider.get();
    }
    colliders[b] = std::move(collider);
  }
}

void BulletRobot::Impl::set_state(const VecNq& q, const VecNv& v) noexcept {
  truth.tau_limit_nm = torque_limits_nm(q.tail<kNj>());
  const Mat3 world_from_base = Quat(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix();
  const Eigen::Isometry3d& base_com = body_from_com[0];
  const Vec3 com_offset = base_com.translation();
  const Mat3 world_from_com = world_from_base * base_com.linear();
  body->setBasePos(to_bt(Vec3(q.head<3>() + world_from_base * com_offset)));
  body->setWorldToBaseRot(to_bt_quaternion(world_from_com).inverse());
  const Vec3 omega_base = config.fixed_base ? Vec3::Zero() : Vec3(v.segment<3>(3));
  const Vec3 v_base = config.fixed_base ? Vec3::Zero() : Vec3(v.head<3>());
  body->setBaseOmega(to_bt(Vec3(world_from_base * omega_base)));
  body->setBaseVel(to_bt(Vec3(world_from_base * (v_base + omega_base.cross(com_offset)))));
  for (int j = 0; j < kNj; ++j) {
    body->setJointPos(j, q[7 + j]);
    body->setJointVel(j, v[6 + j]);
  }
  update_kinematics();
}

void BulletRobot::Impl::read_state(VecNq& q, VecNv& v) const noexcept {
  const Eigen::Isometry3d world_from_com = isometry_of(body->getBaseWorldTransform());
  const Eigen::Isometry3d world_from_base = world_from_com * com_from_body[0];
  const Mat3 r = world_from_base.linear();
  Quat quat(r);
  quat.normalize();
  if (quat.w() < 0.0) quat.coeffs() = -quat.coeffs();
  q.head<3>() = world_from_base.translation();
  q.segment<4>(3) = quat.coeffs();  // x y z w
  const Vec3 omega_base = r.transpose() * to_eigen(body->getBaseOmega());
  const Vec3 com_offset = body_from_com[0].translation();
  v.head<3>() = r.transpose() * to_eigen(body->getBaseVel()) - omega_base.cross(com_offset);
  v.segment<3>(3) = omega_base;
  for (int j = 0; j < kNj; ++j) {
    q[7 + j] = body->getJointPos(j);
    v[6 + j] = body->getJointVel(j);
  }
}

void BulletRobot::Impl::apply_drive_torques() noexcept {
  for (int j = 0; j < kNj; ++j) {
    const double q = body->getJointPos(j);
    double tau = active ? hal::drive_torque_nm(applied, j, q, body->getJointVel(j)) : 0.0;
    const double limit = torque_limit_nm(j, q);
    if (config.saturate_torques) tau = std::clamp(tau, -limit, limit);
    body->addJointTorque(j, tau);
    truth.tau_applied_nm[j] = tau;
    truth.tau_limit_nm[j] = limit;
  }
}

void BulletRobot::Impl::apply_external_wrenches(double t_s) noexcept {
  for (int i = 0; i < wrench_count; ++i) {
    const ExternalWrench& w = wrenches[i];
    const double value = profile_value(w.profile, t_s);
    if (value == 0.0) continue;
    const int b = w.frame.body;
    const Vec3 vec = value * w.axis_world;
    Vec3 force = Vec3::Zero();
    Vec3 torque_about_com = vec;
    if (w.kind == WrenchKind::force) {
      const Vec3 point = body_pose(b) * translation_of(w.frame.placement);
      force = vec;
      torque_about_com = (point - com_pose(b).translation()).cross(force);
    }
    if (b == 0) {
      body->addBaseForce(to_bt(force));
      body->addBaseTorque(to_bt(torque_about_com));
    } else {
      body->addLinkForce(b - 1, to_bt(force));
      body->addLinkTorque(b - 1, to_bt(torque_about_com));
    }
  }
}

void BulletRobot::Impl::accumulate_contacts(double weight) noexcept {
  if (!ground) return;
  const int manifolds = dispatcher->getNumManifolds();
  for (int m = 0; m < manifolds; ++m) {
    const btPersistentManifold* manifold = dispatcher->getManifoldByIndexInternal(m);
    const bool robot_is_a = manifold->getBody1() == ground.get();
    if (!robot_is_a && manifold->getBody0() != ground.get()) continue;
    const auto* collider = btMultiBodyLinkCollider::upcast(robot_is_a ? manifold->getBody0() : manifold->getBody1());
    if (collider == nullptr) continue;
    const int b = collider->m_link + 1;
    for (int k = 0; k < manifold->getNumContacts(); ++k) {
      const btManifoldPoint& pt = manifold->getContactPoint(k);
      // The solver pushes body A along +normal (the normal points from B to A).
      const btVector3 impulse = pt.m_normalWorldOnB * pt.m_appliedImpulse +
                                pt.m_lateralFrictionDir1 * pt.m_appliedImpulseLateral1 +
                                pt.m_lateralFrictionDir2 * pt.m_appliedImpulseLateral2;
      const Vec3 force_n = (robot_is_a ? 1.0 : -1.0) * weight * to_eigen(impulse) / substep_s;
      const bool touching = pt.m_appliedImpulse > 0.0 || pt.getDistance() < 0.0;
      const int child = robot_is_a ? pt.m_index0 : pt.m_index1;
      truth.ground_force_n += force_n;
      int foot = -1;
      for (int f = 0; f < kFeet; ++f) {
        if (foot_body[f] == b && foot_child[f] == child) foot = f;
      }
      if (foot >= 0) {
        truth.foot_force_n[foot] += force_n;
        truth.foot_contact[foot] = truth.foot_contact[foot] || touching;
      } else {
        truth.non_foot_ground_contact = truth.non_foot_ground_contact || touching;
      }
    }
  }
}

void BulletRobot::Impl::update_sensors(bool first) noexcept {
  const double t_s = static_cast<double>(tick) * config.step_s;
  const auto stamp_ns = static_cast<std::int64_t>(std::llround(static_cast<double>(sample_tick) * config.step_s * 1e9));
  truth.time_s = t_s;
  read_state(truth.q, truth.v);

  // IMU: orientation, body rate and specific force (finite difference of the
  // IMU point's world velocity over the tick, minus gravity) in the IMU frame.
  const auto& imu_frame = robot::kFrames[kImuFrame];
  const Eigen::Isometry3d world_from_imu = body_pose(imu_frame.body) * isometry_of(imu_frame.placement);
  const Vec3 omega_world = to_eigen(body->getBaseOmega());
  const Vec3 imu_velocity_world =
      to_eigen(body->getBaseVel()) + omega_world.cross(world_from_imu.translation() - com_pose(0).translation());
  if (first) previous_imu_velocity_world = imu_velocity_world;
  const Vec3 accel_world = (imu_velocity_world - previous_imu_velocity_world) / config.step_s;
  previous_imu_velocity_world = imu_velocity_world;
  const Vec3 gravity_world(0.0, 0.0, -config.gravity_m_s2);
  const Mat3 imu_from_world = world_from_imu.linear().transpose();
  imu.valid = true;
  imu.stamp_ns = stamp_ns;
  ImuTruth imu_truth;
  imu_truth.orientation = Quat(world_from_imu.linear()).normalized();
  imu_truth.angular_rate_rad_s = imu_from_world * omega_world;
  imu_truth.specific_force_m_s2 = imu_from_world * (accel_world - gravity_world);
  sensors.imu(imu_truth, first, imu);

  // Wrist F/T: the external wrenches on the sensor's body, about the sensor origin, sensor axes.
  const auto& ft_frame = robot::kFrames[kWristFtFrame];
  const Eigen::Isometry3d world_from_ft = body_pose(ft_frame.body) * isometry_of(ft_frame.placement);
  Vec3 force = Vec3::Zero();
  Vec3 torque = Vec3::Zero();
  for (int i = 0; i < wrench_count; ++i) {
    const ExternalWrench& w = wrenches[i];
    if (w.frame.body != ft_frame.body) continue;
    const Vec3 vec = profile_value(w.profile, t_s) * w.axis_world;
    if (w.kind == WrenchKind::torque) {
      torque += vec;
    } else {
      const Vec3 point = body_pose(w.frame.body) * translation_of(w.frame.placement);
      force += vec;
      torque += (point - world_from_ft.translation()).cross(vec);
    }
  }
  wrist.valid = true;
  wrist.stamp_ns = stamp_ns;
  const Vec3 force_ft = world_from_ft.linear().transpose() * force;
  const Vec3 torque_ft = world_from_ft.linear().transpose() * torque;
  sensors.wrist(force_ft, torque_ft, wrist);

  Sampled now;
  sensors.joints(truth.q.tail<kNj>(), truth.v.tail<kNj>(), truth.tau_applied_nm, first, now.q_rad, now.qd_rad_s,
                 now.tau_nm);
  now.imu = imu;
  now.wrist = wrist;
  if (first) {
    sampled.fill(now);  // as if at rest there for as long as the latency reaches back
  } else {
    sampled[slot(sample_tick, 0)] = now;
  }
}

// ---- BulletRobot --------------------------------------------------------------

BulletRobot::BulletRobot(const SimConfig& config) : impl_(std::make_unique<Impl>(config)) {}
BulletRobot::~BulletRobot() = default;

hal::LifecycleResult BulletRobot::configure() {
  if (impl_->configured) return hal::LifecycleResult::failure("sim: configure() called twice");
  if (std::string why = check_config(impl_->config); !why.empty()) {
    return hal::LifecycleResult::failure("sim config: " + why);
  }
  if (std::string why = impl_->build(); !why.empty()) return hal::LifecycleResult::failure("sim: " + why);
  impl_->configured = true;
  set_state(impl_->config.initial_q, impl_->config.initial_v);
  return hal::LifecycleResult::success();
}

hal::LifecycleResult BulletRobot::activate() {
  if (!impl_->configured) return hal::LifecycleResult::failure("sim: activate() before configure()");
  impl_->active = true;
  return hal::LifecycleResult::success();
}

void BulletRobot::deactivate() noexcept {
  impl_->active = false;
  impl_->command.mode = hal::CommandMode::disabled;
}

hal::IoStatus BulletRobot::read(hal::Measurements& out) noexcept {
  Impl& s = *impl_;
  if (!s.configured) return hal::IoStatus::error;
  out.sequence = ++s.read_sequence;
  const Impl::Sampled& joints = s.sampled[Impl::slot(s.sample_tick, s.config.latency.joint_measurement_ticks)];
  const Impl::Sampled& sensors = s.sampled[Impl::slot(s.sample_tick, s.config.latency.sensor_measurement_ticks)];
  out.q_rad = joints.q_rad;
  out.qd_rad_s = joints.qd_rad_s;
  out.tau_nm = joints.tau_nm;
  for (auto& drive : out.drives) {
    drive.state = s.active ? hal::DriveState::enabled : hal::DriveState::ready;
    drive.fresh = true;
    drive.fault_code = 0;
    drive.missed_in_row = 0;
  }
  out.stamp_ns = sensors.imu.stamp_ns;
  out.imu = sensors.imu;
  out.wrist = sensors.wrist;
  return hal::IoStatus::ok;
}

hal::IoStatus BulletRobot::write(const hal::JointCommands& cmd) noexcept {
  Impl& s = *impl_;
  if (!s.active) return hal::IoStatus::error;
  const bool finite = cmd.tau_ff_nm.allFinite() && cmd.q_des_rad.allFinite() && cmd.qd_des_rad_s.allFinite() &&
                      cmd.kp_nm_per_rad.allFinite() && cmd.kd_nms_per_rad.allFinite();
  if (!finite) {
    // A broken command never reaches the drives: they fall back to no torque.
    s.command.mode = hal::CommandMode::disabled;
    return hal::IoStatus::error;
  }
  s.command = cmd;
  return hal::IoStatus::ok;
}

bool BulletRobot::add_external_wrench(const ExternalWrench& wrench) noexcept {
  Impl& s = *impl_;
  if (s.wrench_count >= kMaxExternalWrenches) return false;
  s.wrenches[s.wrench_count++] = wrench;
  return true;
}

void BulletRobot::step() noexcept {
  Impl& s = *impl_;
  if (!s.configured) return;
  s.truth.foot_force_n.fill(Vec3::Zero());
  s.truth.foot_contact.fill(false);
  s.truth.ground_force_n.setZero();
  s.truth.non_foot_ground_contact = false;
  const double t0_s = static_cast<double>(s.tick) * s.config.step_s;
  s.written[Impl::slot(s.tick, 0)] = s.command;
  s.applied = s.written[Impl::slot(s.tick, s.config.latency.command_ticks)];
  for (int k = 0; k < s.config.substeps; ++k) {
    // A joint at a stop: its limit rows hold a loaded joint only in more passes than the
    // contacts alone need (in 3, a robot lying on its legs folded its knees 0.5 rad past theirs).
    bool at_a_stop = false;
    for (const auto& limit : s.limits) at_a_stop = at_a_stop || limit->near(s.substep_s);
    s.world->getSolverInfo().m_numIterations = at_a_stop ? s.config.limit_solver_iterations : s.config.solver_iterations;
    s.apply_drive_torques();
    s.apply_external_wrenches(t0_s + k * s.substep_s);
    s.world->stepSimulation(s.substep_s, /*maxSubSteps=*/0, s.substep_s);
    s.accumulate_contacts(1.0 / s.config.substeps);
  }
  ++s.tick;
  ++s.sample_tick;
  s.update_sensors(false);
}

void BulletRobot::hold_still() noexcept {
  Impl& s = *impl_;
  if (!s.configured) return;
  ++s.sample_tick;
  s.update_sensors(false);
}

double BulletRobot::time_s() const noexcept { return static_cast<double>(impl_->tick) * impl_->config.step_s; }

const GroundTruth& BulletRobot::ground_truth() const noexcept { return impl_->truth; }

void BulletRobot::set_state(const VecNq& q, const VecNv& v) noexcept {
  Impl& s = *impl_;
  if (!s.configured) return;
  s.set_state(q, v);
  s.truth.foot_force_n.fill(Vec3::Zero());
  s.truth.foot_contact.fill(false);
  s.truth.ground_force_n.setZero();
  s.truth.non_foot_ground_contact = false;
  s.update_sensors(true);
}

Eigen::Isometry3d BulletRobot::frame_placement(const FrameRef& frame) const noexcept {
  return impl_->body_pose(frame.body) * isometry_of(frame.placement);
}

double BulletRobot::lowest_foot_clearance_m() const noexcept {
  double lowest = std::numeric_limits<double>::infinity();
  for (int f = 0; f < kFeet; ++f) {
    const auto& foot = robot::kFrames[kFootFrames[f]];
    lowest = std::min(lowest, frame_placement(FrameRef{foot.body, foot.placement}).translation().z() - kFootRadius_m);
  }
  return lowest;
}

const SimConfig& BulletRobot::config() const noexcept { return impl_->config; }

const SensorModel& BulletRobot::sensor_model() const noexcept { return impl_->sensors; }

}  // namespace springbok::sim
