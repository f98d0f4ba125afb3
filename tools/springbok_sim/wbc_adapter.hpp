// controller.type: wbc — the paper's whole-body controller in the simulator.
//
// For `controller.settle_s` seconds the stand controller holds the initial
// posture while the robot settles on its feet; then the WBC takes over, holds
// the pose of that instant as its reference (set_reference) and the template's
// reference response starts. The WBC reads the base pose and twist from the
// simulator's ground truth, or with `controller.params.estimator` from
// springbok::est::BaseEstimator (IMU + leg kinematics, as on hardware), the
// measured joint states and the wrist F/T sensor. All four feet are in stance,
// or with `controller.params.gait` springbok::gait::TrotGait decides which
// feet are in stance and where the swing feet go (from the WBC's start), in the
// trunk's horizontal frame, its footholds' pattern centred under the static ZMP
// of the weight and the measured wrist wrench.
//
// After each physics step it logs the measured base and EE displacements from
// the reference pose (world), the template driven by the measured wrist force,
// F_e, the foot forces, the QP status and iterations and the controller's
// compute time; at the end it scores the run (nrmse, steady_state_error,
// peak_deviation, chirp_gain_db_error, qp_failures, max_torque_ratio,
// joint_limit_hit, tick_us). Definitions: tools/scenarios/README.md.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "controller.hpp"
#include "scenario.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/gait/trot.hpp"
#include "springbok/wbc/impedance_template.hpp"
#include "springbok/wbc/stand_controller.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::simtool {

class WbcAdapter final : public Controller {
 public:
  // Throws ScenarioError naming the bad controller.params field.
  explicit WbcAdapter(const Scenario& scenario);
  ~WbcAdapter() override;

  void tick(const hal::Measurements& m, const sim::GroundTruth& truth, hal::JointCommands& out) noexcept override;
  std::string csv_columns() const override;
  void after_step(const sim::GroundTruth& truth, std::string& row) override;
  std::string summary_fields() const override;

 private:
  static constexpr int kAxes = 6;  // base x y z, ee x y z
  // The gait's footholds shift (frame H) that centres them under the static ZMP.
  Vec3 footholds_shift_h(const hal::Measurements& m, const Mat3& yaw) noexcept;
  struct Sample {
    double time_s;
    std::array<double, kAxes> measured;
    std::array<double, kAxes> reference;
    Vec3 force_world_n;
  };

  wbc::WbcParams params_;
  double dt_s_;
  double settle_s_;
  bool step_profile_ = false;                       // only step/constant forces: steady state is scored
  std::optional<sim::ForceProfile> chirp_;          // the first chirp, for the gain estimate
  Vec3 chirp_axis_ = Vec3::UnitX();
  std::unique_ptr<wbc::StandController> stand_;
  std::unique_ptr<wbc::WholeBodyController> wbc_;
  std::unique_ptr<wbc::TemplateReference> template_;
  std::unique_ptr<est::BaseEstimator> estimator_;   // null: ground truth
  std::unique_ptr<gait::TrotGait> gait_;            // null: four feet in stance
  double wbc_start_s_ = 0.0;
  std::array<bool, kFeet> stance_{true, true, true, true};
  std::uint64_t stance_changes_ = 0;
  bool estimator_ok_ = true;                        // every update since reset was ok
  double estimator_velocity_sq_sum_ = 0.0;          // vs ground truth, WBC ticks
  double estimator_position_max_m_ = 0.0;
  std::uint64_t estimator_samples_ = 0;
  Vec3 truth_before_step_p_ = Vec3::Zero(), truth_before_step_v_ = Vec3::Zero();
  dyn::Model model_;
  std::unique_ptr<dyn::Data> data_;
  wbc::WbcInput input_;
  bool active_ = false;
  bool ticked_ = false;                              // the WBC ran this tick
  double tick_us_ = 0.0;
  std::vector<Sample> samples_;
  std::vector<double> tick_us_all_;
  double max_torque_ratio_ = 0.0;
  std::uint64_t fallback_ticks_ = 0;
  std::uint64_t qp_from_hint_ticks_ = 0;  // ticks whose QP was solved on the last tick's active set
  bool joint_limit_hit_ = false;
  std::string joint_limit_joint_;
};

}  // namespace springbok::simtool
