// One time-step interface over the integrators the charts compare (corde_charts,
// corde_accuracy): the explicit ones through Rod::step, backward Euler and BDF2 through
// ImplicitEuler on the rod itself (the charts' scenes have no contacts). Library only, no ROS.
#pragma once

#include <ctime>
#include <string>

#include "corde_sim/integrators/implicit_step.h"
#include "corde_sim/rod/rod.h"

namespace corde {
namespace charts {

constexpr double kPi = 3.14159265358979323846;

// kSplitRotationScaled: split_rotation on a rod whose tilt inertia is scaled by
// lifting_inertia_scale() (rotational_inertia_scale: auto; docs/model.md). Work-precision only.
enum class Method {
  kSemiImplicitEuler,
  kSplitRotation,
  kImplicitEuler,
  kBdf2,
  kSplitRotationScaled
};
// The stability map and the scaling (BDF2 runs the same Newton solve as backward Euler).
constexpr Method kMethods[] = {Method::kSemiImplicitEuler, Method::kSplitRotation,
                               Method::kImplicitEuler};
// The work-precision charts.
constexpr Method kWorkMethods[] = {Method::kSemiImplicitEuler, Method::kSplitRotation,
                                   Method::kImplicitEuler, Method::kBdf2};

inline const char* method_name(Method m) {
  switch (m) {
    case Method::kSemiImplicitEuler:
      return "semi_implicit_euler";
    case Method::kSplitRotation:
      return "split_rotation";
    case Method::kImplicitEuler:
      return "implicit_euler";
    case Method::kBdf2:
      return "bdf2";
    case Method::kSplitRotationScaled:
      return "split_rotation_scaled";
  }
  return "unknown";
}

inline bool is_explicit(Method m) { return m != Method::kImplicitEuler && m != Method::kBdf2; }

class Stepper {
 public:
  explicit Stepper(Method m, ImplicitOptions options = ImplicitOptions())
      : method_(m), implicit_(options) {
    implicit_.set_second_order(m == Method::kBdf2);
  }
  // One step from t to t + h; false when Newton did not converge (implicit only).
  bool step(Rod& rod, double t, double h, const Vec3& gravity) {
    if (!is_explicit(method_)) {
      const ImplicitResult r = implicit_.step(rod, t, h, gravity);
      iterations_ += r.iterations;
      relative_residual_ = r.reference > 0.0 ? r.residual / r.reference : r.residual;
      if (!r.converged) ++failures_;
      return r.converged;
    }
    rod.step(t, h, gravity,
             method_ == Method::kSemiImplicitEuler ? Integrator::kSemiImplicitEuler
                                                   : Integrator::kSplitRotation);
    return true;
  }
  Method method() const { return method_; }
  long newton_iterations() const { return iterations_; }
  long newton_failures() const { return failures_; }
  // |grad Phi| / its reference scale after the last implicit step (0 for explicit methods).
  double relative_residual() const { return relative_residual_; }

 private:
  Method method_;
  ImplicitEuler implicit_;
  long iterations_ = 0, failures_ = 0;
  double relative_residual_ = 0.0;
};

// Process CPU time (s): less sensitive to other load on a shared machine than wall time.
inline double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

}  // namespace charts
}  // namespace corde
