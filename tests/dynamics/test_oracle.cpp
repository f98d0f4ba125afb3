// springbok::dyn against the reference states (RBDL oracle, FORMAT.md): every
// block of every state_*.txt, each computed through the public API, both by the
// single algorithms and by the one-pass compute_tick.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <memory>

#include "reference_states.hpp"
#include "springbok/dynamics/dynamics.hpp"

namespace {
using namespace springbok;
using springbok::test::block_error;
using springbok::test::kReferenceTolerance;
using springbok::test::to_matrix;

class Oracle : public ::testing::Test {
 protected:
  void expect_block(const state_file::StateFile& file, const std::string& name,
                    const Eigen::MatrixXd& mine, const std::string& how) {
    const auto& ref = file.require(name, static_cast<int>(mine.rows()), static_cast<int>(mine.cols()));
    const double err = block_error(name, mine, to_matrix(ref));
    EXPECT_LE(err, kReferenceTolerance) << file.source << " block " << name << " (" << how << ")";
    double& worst = max_error_[name];
    worst = std::max(worst, err);
  }

  // The feet's and the end effector's frames, Jacobians and dJ/dt v held in `d`, each named in a
  // failure by the algorithm that computed it (`fk`, `jacobians`, `jacobians_dot`).
  void expect_frame_blocks(const state_file::StateFile& file, const dyn::Data& d, const std::string& fk,
                           const std::string& jacobians, const std::string& jacobians_dot) {
    static constexpr const char* kFeetNames[kFeet] = {"lf_foot", "rf_foot", "lh_foot", "rh_foot"};
    for (int f = 0; f < kFeet; ++f) {
      const std::string name = kFeetNames[f];
      expect_block(file, "p_" + name, d.frames[kFootFrames[f]].translation.transpose(), fk);
      expect_block(file, "J_" + name, d.J_feet[f], jacobians);
      expect_block(file, "dJv_" + name, d.dJv_feet[f].transpose(), jacobians_dot);
    }
    expect_block(file, "p_ee", d.frames[kEeFrame].translation.transpose(), fk);
    expect_block(file, "R_ee", d.frames[kEeFrame].rotation, fk);
    expect_block(file, "J_ee", d.J_ee, jacobians);
    expect_block(file, "dJv_ee", d.dJv_ee.transpose(), jacobians_dot);
  }

  void TearDown() override {
    for (const auto& [name, err] : max_error_) std::printf("  max error %-12s %.3g\n", name.c_str(), err);
  }

  std::map<std::string, double> max_error_;
};

TEST_F(Oracle, EveryBlockOfEveryReferenceState) {
  const auto files = springbok::test::reference_state_files(robot::kRobotName);
  ASSERT_GE(files.size(), 1u) << "no state_*.txt under " << springbok::test::data_dir();
  const dyn::Model model{Rotors::none};  // the URDF alone, as the reference states (and Pinocchio)
  auto data = std::make_unique<dyn::Data>();
  for (const auto& path : files) {
    const auto file = state_file::read(path);
    const auto in = state_file::dynamics_input(file);

    expect_block(file, "tau", dyn::rnea(model, *data, in.q, in.v, in.vdot).transpose(), "rnea");
    expect_block(file, "M", dyn::crba(model, *data, in.q), "crba");
    expect_block(file, "h", dyn::nonlinear_effects(model, *data, in.q, in.v).transpose(), "nonlinear_effects");
    expect_block(file, "g", dyn::gravity(model, *data, in.q).transpose(), "gravity");
    expect_block(file, "vdot_aba", dyn::aba(model, *data, in.q, in.v, in.tau_aba).transpose(), "aba");
    dyn::point_jacobians(model, *data, in.q);
    dyn::point_jacobians_dot_times_v(model, *data, in.q, in.v);
    expect_frame_blocks(file, *data, "forward_kinematics", "point_jacobians", "point_jacobians_dot_times_v");

    // The one-pass tick, on a fresh workspace, must give the same blocks.
    auto tick = std::make_unique<dyn::Data>();
    dyn::compute_tick(model, *tick, in.q, in.v);
    expect_block(file, "M", tick->M, "compute_tick");
    expect_block(file, "h", tick->nle.transpose(), "compute_tick");
    expect_frame_blocks(file, *tick, "compute_tick", "compute_tick", "compute_tick");
  }
}

}  // namespace
