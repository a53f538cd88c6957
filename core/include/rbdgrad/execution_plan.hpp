// What one forward-dynamics gradient computes (issue 8's execution plan): which derivative columns,
// whether gravity and external forces enter (and on which bodies), and whether M^-1 comes from the
// caller. The daemon builds one per scene and hands it to every backend, which skips what it
// excludes; without a scene a plan is derived per request (plan_request).
//
// GradientStages is the compile-time part of a plan: the stages interleaved with the hot loops
// (the d/dq and d/dqd columns, the external-force pass) are template flags, so each stage set is
// its own instantiation, the code a build without those stages would have. dispatch_stages picks
// the instantiation once per call. Gravity and a supplied M^-1 are chosen per call outside the
// loops: gravity is the root's acceleration (a value, not a stage, in the world-frame passes) and
// M^-1 is a whole step after them.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <utility>

#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad {

/// A set of bodies (those external forces act on), fixed size so that plans copy without allocating.
class BodyMask {
 public:
  static constexpr int kCapacity = 256;  // bodies 0..255; a larger model takes forces on all bodies or none

  /// Adds `body`; false (and nothing added) when it is outside [0, kCapacity).
  bool set(int body);
  bool test(int body) const;
  bool empty() const;
  int count() const;
  /// The lowest body >= nv in the set, or -1: a plan for a model with nv bodies must have none.
  int first_at_or_above(int nv) const;

  /// Calls f(i) for each body i < nv of the set, in increasing order.
  template <class F>
  void for_each(int nv, F&& f) const {
    for (int w = 0; w * 64 < nv && w < kWords; ++w) {
      std::uint64_t bits = words_[static_cast<std::size_t>(w)];
      if (nv - w * 64 < 64) bits &= (std::uint64_t{1} << (nv - w * 64)) - 1;
      while (bits != 0) {
        f(w * 64 + std::countr_zero(bits));
        bits &= bits - 1;
      }
    }
  }

  friend bool operator==(const BodyMask&, const BodyMask&) = default;

 private:
  static constexpr int kWords = kCapacity / 64;
  std::array<std::uint64_t, kWords> words_{};
};

enum class ExternalForces : unsigned char {
  kNone,        // no external forces: their terms are not computed and fext is never read
  kAllBodies,   // fext holds a force for every body
  kSomeBodies,  // only the bodies of ExecutionPlan::fext_bodies carry forces; the others are never read
};

struct ExecutionPlan {
  bool dqdd_dq = true;   // d qdd / d q is computed (else ws.dqdd_dq is not written)
  bool dqdd_dqd = true;  // d qdd / d qd is computed (else ws.dqdd_dqd is not written)
  bool gravity = true;   // false: computed as if the model's gravity were zero
  ExternalForces external_forces = ExternalForces::kNone;
  BodyMask fext_bodies;        // the bodies with forces, with kSomeBodies
  bool minv_supplied = false;  // M^-1(q) comes from the caller and is not computed

  friend bool operator==(const ExecutionPlan&, const ExecutionPlan&) = default;
};

/// The bodies whose fext is read under `plan`: its mask with kSomeBodies, else null (every body).
inline const BodyMask* forced_bodies(const ExecutionPlan& plan) {
  return plan.external_forces == ExternalForces::kSomeBodies ? &plan.fext_bodies : nullptr;
}

/// The plan of one request without a scene: the derivative columns that `outputs` (OutputFlag bits)
/// ask for, gravity unless the model's is zero, forces on every body when fext is given, M^-1
/// supplied when supplied_minv is given (only whether the pointers are null matters).
template <class S>
ExecutionPlan plan_request(const ModelTpl<S>& model, std::uint32_t outputs, const void* fext,
                           const void* supplied_minv);

/// Checks a plan against a model of `nv` bodies and a request's data: invalid_argument when it
/// names a body the model does not have, has forces but no fext, or a supplied M^-1 but none given.
Status check_plan(int nv, const ExecutionPlan& plan, bool has_fext, bool has_minv);

/// The stages compiled into one instantiation of the gradient algorithms (a structural type: a
/// template argument).
struct GradientStages {
  bool dq = true;    // the d/dq columns: beta, the d tau/d q terms, -M^-1 d tau/d q
  bool dqd = true;   // the d/dqd columns: the d tau/d qd terms, -M^-1 d tau/d qd
  bool fext = true;  // the external-force pass (all bodies or a BodyMask's)

  friend constexpr bool operator==(const GradientStages&, const GradientStages&) = default;
};
inline constexpr GradientStages kAllStages{};
inline constexpr int kNumStageSets = 8;

/// The stage set of index 0..7 (bit 0 dq, bit 1 dqd, bit 2 fext) and back.
constexpr GradientStages stage_set(int index) { return {(index & 1) != 0, (index & 2) != 0, (index & 4) != 0}; }
constexpr int stage_index(const GradientStages& s) { return (s.dq ? 1 : 0) | (s.dqd ? 2 : 0) | (s.fext ? 4 : 0); }

/// The stages of the forward-dynamics gradient under `plan`.
constexpr GradientStages gradient_stages(const ExecutionPlan& plan) {
  return {plan.dqdd_dq, plan.dqdd_dqd, plan.external_forces != ExternalForces::kNone};
}

namespace detail {
template <class F, int... kI>
Status dispatch_stages(int index, F& f, std::integer_sequence<int, kI...>) {
  Status result;
  // one comparison per stage set; the compiler turns the chain into a jump table
  (void)((index == kI && (result = f.template operator()<stage_set(kI)>(), true)) || ...);
  return result;
}
}  // namespace detail

/// Calls f.template operator()<kStages>() with kStages == stages: the one runtime-to-compile-time
/// switch of a call, which instantiates f for every stage set.
template <class F>
Status dispatch_stages(const GradientStages& stages, F&& f) {
  return detail::dispatch_stages(stage_index(stages), f, std::make_integer_sequence<int, kNumStageSets>{});
}

/// Explicitly instantiates MACRO(S, INDEX) for each stage set (see stage_set).
#define RBDGRAD_FOR_EACH_STAGE_SET(MACRO, S) \
  MACRO(S, 0) MACRO(S, 1) MACRO(S, 2) MACRO(S, 3) MACRO(S, 4) MACRO(S, 5) MACRO(S, 6) MACRO(S, 7)

}  // namespace rbdgrad
