#include "host/latency_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "kernel/axi_layout.hpp"

namespace rbdgrad::fpga {
namespace {

using Cycles = std::int64_t;

int ceil_log2(int n) {
  int levels = 0;
  while ((1 << levels) < n) ++levels;
  return levels;
}

Cycles ceil_div(Cycles a, Cycles b) { return (a + b - 1) / b; }

// The critical paths of the kernel's building blocks (gradient_kernel.hpp, namespace detail).
// cross_motion_S and cross_force_S cost nothing: moves, and negations that fold into the adder
// that consumes them.
struct Depths {
  Cycles mul, add, read, iter;

  // an n-term dot product as a tree: one multiplier level, ceil(log2 n) adder levels (the code
  // writes chains; HLS's expression balancing of integer arithmetic makes them trees: assumed)
  Cycles tree(int terms) const { return mul + add * ceil_log2(terms); }
  Cycles rotate() const { return tree(3); }  // rotate, rotate_back: three 3-term rows side by side
  Cycles cross() const { return mul + add; }  // two products, one subtraction
  // transform_motion [E w; E (v - r x w)]: cross, subtract, rotate
  Cycles transform_motion() const { return cross() + add + rotate(); }
  // transform_force_back [E^T n + r x (E^T f); E^T f]: rotate_back, cross, add
  Cycles transform_force_back() const { return rotate() + cross() + add; }
  Cycles cross_force() const { return cross() + add; }  // two crosses summed
  Cycles mul66() const { return tree(6); }

  // a + b + c for operands ready at t0, t1, t2: the two first summed, then the last
  Cycles sum3(Cycles t0, Cycles t1, Cycles t2) const {
    Cycles t[3] = {t0, t1, t2};
    std::sort(t, t + 3);
    return std::max(t[1] + add, t[2]) + add;
  }
};

// How the loops run: as written, or with paper 000's parallelism (see the header).
struct Schedule {
  int column_passes;       // passes of the loops over the columns that run (0: none runs)
  bool overlap_body;       // a link's own values computed alongside its columns
  bool siblings_parallel;  // the sweeps cost one link per level of the tree
  bool pipeline_unmarked;  // loops without a pragma pipelined at II 1
};

// rnea_gradient's forward sweep, one link: v, a, f of the body. Each line is the cycle its value
// is ready at, from the start of the iteration.
Cycles forward_body(const Depths& d) {
  const Cycles x = d.read + d.transform_motion();  // X vp, X ap (E, r, vp, ap read)
  const Cycles v = x + d.add;                      // v = X vp + S qd
  const Cycles a = v + d.mul + d.add;              // a = X ap + (v x S) qd (+ S qdd: no product)
  const Cycles h = v + d.mul66();                  // h = I v
  const Cycles ia = a + d.mul66();                 // I a
  const Cycles vxh = h + d.cross_force();          // v x* h
  return std::max(ia, vxh) + d.add;                // f = I a + v x* h
}

// one pass of the forward sweep's column loop: column j's dv, da, df (the pass's columns side by
// side). A root link's parent columns are zero: no read of them and no transform. The datapath is
// the same for a column of q and of qd (their own terms are a move and an add at the same place,
// and HLS builds one datapath for both, the range being the mode's, known only at run time).
Cycles forward_column(const Depths& d, bool root) {
  const Cycles x = d.read + (root ? 0 : d.transform_motion());  // X dv_par, X da_par; v, h, Xv, Xa read
  const Cycles dv = x + d.add;                                 // + (X v_par) x S for q_i, + S for qd_i
  const Cycles da = dv + d.mul + d.add;  // + (dv x S) qd; the joint's own term joins the other summand
  const Cycles ida = da + d.mul66();     // I da
  const Cycles idv = dv + d.mul66();     // I dv
  const Cycles c1 = dv + d.cross_force();    // dv x* h
  const Cycles c2 = idv + d.cross_force();   // v x* (I dv)
  return d.sum3(ida, c1, c2);                // df
}

// one pass of the backward sweep's column loop: dc = S^T df, and df_par += X^T df (+ X^T (S x* f)
// for j = i) with the two transforms side by side. A root link only stores dc. The j = i branch is
// never taken in the qd columns, but it is in the datapath whichever range the mode selects: the
// pass is counted as deep in both.
Cycles backward_column(const Depths& d, bool root) {
  if (root) return d.read;
  const Cycles t = d.read + d.transform_force_back();
  return d.sum3(d.read, t, t);
}

// the backward sweep's force into the parent after the column loop: f_par += X^T f
Cycles backward_force(const Depths& d, bool root) {
  return root ? 0 : d.read + d.transform_force_back() + d.add;
}

// a loop over n joints without a pragma whose iteration is `depth` deep
Cycles element_loop(const Depths& d, const Schedule& s, int n, Cycles depth) {
  if (s.pipeline_unmarked) return (n - 1) + depth + d.iter;
  return n * (depth + d.iter);
}

// WideDot::dot over n terms: read, multiply, accumulate; pipelined its II is the accumulator's add
Cycles dot(const Depths& d, const Schedule& s, int n) {
  const Cycles step = d.read + d.mul + d.add;
  if (s.pipeline_unmarked) return (n - 1) * d.add + step + d.iter;
  return n * (step + d.iter);
}

// A sweep's cost from each link's: one after another (as written), or one link per tree level
// (siblings side by side: the level costs its dearest link).
Cycles sweep(const std::vector<int>& level, const std::vector<Cycles>& link, bool siblings_parallel) {
  if (!siblings_parallel) {
    Cycles total = 0;
    for (Cycles c : link) total += c;
    return total;
  }
  const int levels = *std::max_element(level.begin(), level.end()) + 1;
  std::vector<Cycles> dearest(static_cast<std::size_t>(levels), 0);
  for (std::size_t i = 0; i < link.size(); ++i) {
    Cycles& c = dearest[static_cast<std::size_t>(level[i])];
    c = std::max(c, link[i]);
  }
  Cycles total = 0;
  for (Cycles c : dearest) total += c;
  return total;
}

struct Sweeps {
  Cycles forward = 0, backward = 0;
};

// rnea_gradient: the forward sweep over links (iteration: body, then the column passes), then
// the backward sweep (tau read, the column passes, the force into the parent)
Sweeps rnea_gradient(const Depths& d, const Schedule& s, const std::vector<int>& parent,
                     const std::vector<int>& level) {
  const std::size_t n = parent.size();
  std::vector<Cycles> fwd(n), bwd(n);
  for (std::size_t i = 0; i < n; ++i) {
    const bool root = parent[i] < 0;
    const Cycles columns_fwd = s.column_passes * (forward_column(d, root) + d.iter);
    const Cycles columns_bwd = s.column_passes * (backward_column(d, root) + d.iter);
    if (s.overlap_body) {
      fwd[i] = d.iter + std::max(forward_body(d), columns_fwd);
      bwd[i] = d.iter + d.read + std::max(columns_bwd, backward_force(d, root));
    } else {
      fwd[i] = d.iter + forward_body(d) + columns_fwd;
      bwd[i] = d.iter + d.read + columns_bwd + backward_force(d, root);
    }
  }
  return {sweep(level, fwd, s.siblings_parallel), sweep(level, bwd, s.siblings_parallel)};
}

// fd_gradient, phase by phase. The columns that run change only the column loops' pass count
// (s.column_passes): the three column loops (forward sweep, backward sweep, -M^-1 dc/du) run
// ceil(k / U) passes each, so every phase with columns is its columnless part plus
// column_passes times one pass. The output words do not change (the top writes zeros for the
// columns left out), nor does anything outside those loops.
PhaseCycles fd_gradient(const Depths& d, const Schedule& s, const KernelTiming& timing, InputKind input,
                        const std::vector<int>& parent, const std::vector<int>& level) {
  const int n = static_cast<int>(parent.size());
  PhaseCycles p;
  // joint_transforms: PIPELINE II; an iteration reads sin, cos and R0 and mixes two columns
  // (c R0 + s R0'; a prismatic joint's p0 + q R0 e_z is as deep)
  p.joint_transforms = (n - 1) * Cycles{timing.joint_transform_ii} + d.read + d.mul + d.add + d.iter;
  if (input == InputKind::kTau) {
    // zeros, the first pass, bias = tau - c, then qdd_i = M^-1 row i . bias (rounded once). The
    // first pass is the bias alone (rnea_gradient(..., 0u)): its column loops run no pass whatever
    // the mode, since the second pass writes every column it computes.
    Schedule bias = s;
    bias.column_passes = 0;
    const Sweeps first = rnea_gradient(d, bias, parent, level);
    p.qdd = element_loop(d, s, n, 0) + first.forward + first.backward + element_loop(d, s, n, d.read + d.add) +
            n * (dot(d, s, n) + d.add + d.iter);
  } else {
    p.qdd = element_loop(d, s, n, d.read);
  }
  const Sweeps second = rnea_gradient(d, s, parent, level);
  p.forward_sweep = second.forward;
  p.backward_sweep = second.backward;
  // -M^-1 dc/du: the column passes, each a loop over rows of one dot, rounded and negated
  p.minv_product = s.column_passes * (d.iter + n * (dot(d, s, n) + 2 * d.add + d.iter));
  return p;
}

// cycles to stream `words` 32-bit words through a port of `bits` at the burst efficiency
Cycles stream_cycles(const KernelTiming& timing, int words) {
  const Cycles beats = ceil_div(words, timing.axi_port_bits / 32);
  return static_cast<Cycles>(std::ceil(static_cast<double>(beats) / timing.axi_burst_efficiency));
}

Status at_least(const char* field, int value, int min) {
  if (value >= min) return Status::ok();
  return invalid_argument(std::string("KernelTiming.") + field + " must be at least " + std::to_string(min) +
                          ", got " + std::to_string(value));
}

}  // namespace

Status check_timing(const KernelTiming& timing) {
  for (const auto& [field, value, min] : {std::tuple{"multiplier_cycles", timing.multiplier_cycles, 1},
                                          std::tuple{"adder_cycles", timing.adder_cycles, 1},
                                          std::tuple{"memory_read_cycles", timing.memory_read_cycles, 1},
                                          std::tuple{"loop_iteration_overhead_cycles",
                                                     timing.loop_iteration_overhead_cycles, 0},
                                          std::tuple{"column_unroll", timing.column_unroll, 1},
                                          std::tuple{"joint_transform_ii", timing.joint_transform_ii, 1},
                                          std::tuple{"axi_latency_cycles", timing.axi_latency_cycles, 0}}) {
    if (Status s = at_least(field, value, min); !s) return s;
  }
  const int bits = timing.axi_port_bits;
  if (bits < 32 || bits > 1024 || (bits & (bits - 1)) != 0)
    return invalid_argument("KernelTiming.axi_port_bits must be a power of two from 32 to 1024, got " +
                            std::to_string(bits));
  const double eff = timing.axi_burst_efficiency;
  if (!(eff > 0 && eff <= 1))
    return invalid_argument("KernelTiming.axi_burst_efficiency must be in (0, 1], got " + std::to_string(eff));
  if (!(std::isfinite(timing.clock_mhz) && timing.clock_mhz > 0))
    return invalid_argument("KernelTiming.clock_mhz must be finite and positive, got " +
                            std::to_string(timing.clock_mhz));
  if (!(std::isfinite(timing.host_round_trip_us) && timing.host_round_trip_us >= 0))
    return invalid_argument("KernelTiming.host_round_trip_us must be finite and not negative, got " +
                            std::to_string(timing.host_round_trip_us));
  if (!(std::isfinite(timing.pcie_gbytes_per_s) && timing.pcie_gbytes_per_s > 0))
    return invalid_argument("KernelTiming.pcie_gbytes_per_s must be finite and positive, got " +
                            std::to_string(timing.pcie_gbytes_per_s));
  return Status::ok();
}

Status estimate_latency(const Model& model, const KernelTiming& timing, std::size_t n_states, InputKind input,
                        unsigned columns, LatencyEstimate& out) {
  if (Status s = check_timing(timing); !s) return s;
  if ((columns & ~kAllColumns) != 0)
    return invalid_argument("columns is " + std::to_string(columns) + ": expected kColumnsDq, kColumnsDqd, both or 0");
  const int n = model.nv;
  if (n < 1) return invalid_argument("the model has no moving joint");
  if (n > kDeviceMaxNv)
    return failed_precondition("the model has " + std::to_string(n) + " joints, the FPGA kernel takes at most " +
                               std::to_string(kDeviceMaxNv));
  if (model.parent.size() != static_cast<std::size_t>(n))
    return invalid_argument("the model's parent array has " + std::to_string(model.parent.size()) +
                            " entries for nv = " + std::to_string(n));
  if (n_states < 1) return invalid_argument("a batch has at least one state");
  // each joint's level in the tree (0 for the roots), from parent[i] < i
  std::vector<int> level(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const int par = model.parent[static_cast<std::size_t>(i)];
    if (par < -1 || par >= i)
      return invalid_argument("joint " + std::to_string(i) + " has parent " + std::to_string(par) +
                              ": parents come first (depth-first order)");
    level[static_cast<std::size_t>(i)] = par < 0 ? 0 : level[static_cast<std::size_t>(par)] + 1;
  }

  const Depths d{timing.multiplier_cycles, timing.adder_cycles, timing.memory_read_cycles,
                 timing.loop_iteration_overhead_cycles};
  // the columns that run, as the kernel's loops take them: [begin, end) of the 2 nv columns (q
  // then qd), nv for one derivative, none for qdd alone (begin n, end 0: a loop that does not
  // start); with UNROLL factor U a loop over k of them runs ceil(k / U) passes, the last one with
  // k mod U columns when U does not divide k, counted as long as a full one (the idle datapath
  // does not shorten it)
  const ColumnRange range(columns, n);
  const int k = std::max(range.end - range.begin, 0);
  const Schedule as_written{static_cast<int>(ceil_div(k, timing.column_unroll)), false, false,
                            timing.pipeline_unmarked_loops};
  // idealised: every column its own datapath, one pass when any runs
  const Schedule ideal{k > 0 ? 1 : 0, true, true, timing.pipeline_unmarked_loops};

  LatencyEstimate e;
  e.column_passes = as_written.column_passes;
  e.phases = fd_gradient(d, as_written, timing, input, model.parent, level);
  e.cycles_per_gradient = e.phases.total();
  e.ideal_cycles_per_gradient = fd_gradient(d, ideal, timing, input, model.parent, level).total();
  // the top function: the state's words in (gmem0), the gradient, its words out (gmem1), one
  // state after another; each transfer pays the port's latency once
  const int in_words = AxiLayout::in_words(n), out_words = AxiLayout::out_words(n);
  e.transfer_cycles_per_state =
      2 * Cycles{timing.axi_latency_cycles} + stream_cycles(timing, in_words) + stream_cycles(timing, out_words);
  e.robot_transfer_cycles = timing.axi_latency_cycles + stream_cycles(timing, AxiLayout::robot_words(n));
  const Cycles per_state = e.transfer_cycles_per_state + e.cycles_per_gradient;
  if (n_states > static_cast<std::size_t>((std::numeric_limits<Cycles>::max() - e.robot_transfer_cycles) / per_state))
    return invalid_argument("a batch of " + std::to_string(n_states) + " states is too large to estimate");
  e.batch_cycles = e.robot_transfer_cycles + static_cast<Cycles>(n_states) * per_state;

  const double mhz = timing.clock_mhz;  // cycles per microsecond
  e.gradient_us = static_cast<double>(e.cycles_per_gradient) / mhz;
  e.ideal_gradient_us = static_cast<double>(e.ideal_cycles_per_gradient) / mhz;
  e.kernel_us = static_cast<double>(e.batch_cycles) / mhz;
  // the buffers of states in and results out (the robot's words stay on the card between batches)
  const double bytes = static_cast<double>(n_states) * (in_words + out_words) * sizeof(DeviceWord);
  e.host_transfer_us = bytes / (timing.pcie_gbytes_per_s * 1e3);  // 1 GB/s = 1e3 bytes per microsecond
  e.batch_us = timing.host_round_trip_us + e.host_transfer_us + e.kernel_us;
  out = e;
  return Status::ok();
}

}  // namespace rbdgrad::fpga
