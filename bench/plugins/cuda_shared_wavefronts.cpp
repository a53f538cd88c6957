// The block kernel's shared-memory wavefronts for one state, counted on the host: its device code
// (the compact lean build with the tree fixed, as the plugin compiles it for the robot: M^-1 by
// the tree's chains and columns, the products by the tree's blocks) runs as plain C++ on a scalar
// type that traces every access of the working set (shared_access_trace.hpp), its items spread
// over the group's threads as on the GPU. Prints the wavefronts pass by pass and the sites whose
// bank conflicts cost the most (addr2line names their source lines), so that a change to the
// layout or to the items' mapping can be weighed before a GPU times it. A model of the banks, not
// a measurement: Nsight Compute's counts (scripts/gpu-checks.sh, STEPS=profile) are the measured
// ones.
//
//   cuda_shared_wavefronts [--robot talos_reduced|iiwa14] [--threads 128] [--top 25] [--pass P]
// (--pass: the source lines of pass P alone; --top 0 lists none; the lines by excess, or with
// --by-wavefronts by wavefronts)
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "shared_access_trace.hpp"

#include "device/block_fused_state.hpp"
#include "flat_model.hpp"
#include "gradient_workload.hpp"
#include "host_tree_view.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using S = shared_trace::Traced;

// One f64 state from tau, outputs d qdd/d q and d qdd/d qd (the benchmark's workload), traced
template <int NV, int LEVELS>
bool trace_state(const rbdgrad::Model& model, int threads) {
  namespace cuda = rbdgrad::cuda;
  // the tree fixed as in the kernel the plugin compiles for the robot (its tables found at run time)
  using Model = cuda::HostTreeView<S, NV, LEVELS>;
  const cuda::FlatModel<S> flat(model);
  const Model m(flat.host_view());
  cuda::GradientWorkload<S> work(model.nv, 1, 5);
  const cuda::BatchPointers<S>& b = work.batch;
  constexpr bool kLean = true;
  const cuda::BlockMatrices matrices = cuda::block_matrices(model.nv, flat.matrix_scalars, true, false);
  std::vector<S> shared(cuda::BlockWorkspace<S>::scalars(model.nv, false, matrices, kLean));
  const cuda::BlockWorkspace<S> w(shared.data(), model.nv, false, matrices, kLean);
  shared_trace::recorder.watch(shared.data(), shared.size() * sizeof(S), threads);
  cuda::ThreadGroup g;
  g.size = threads;
  g.trace = &shared_trace::recorder;
  cuda::block_load_inputs(m.nv, w, b, 0, g);
  cuda::block_evaluate_state<S, Model, S, cuda::block_stages::kPerBatch, true, kLean>(m, w, b, 0, true, g);
  if (work.status[0] != 0) std::fprintf(stderr, "warning: the state failed (status %u)\n", work.status[0]);
  return work.status[0] == 0;
}

// file:line of a site's innermost frame outside the tracer (its path from the device folder on)
std::string source_line(const std::vector<std::string>& frames) {
  for (const std::string& f : frames) {
    if (f.find("shared_access_trace.hpp") != std::string::npos || f.find("scalar_pairs.hpp") != std::string::npos)
      continue;
    const auto slash = f.rfind("/device/");
    return slash == std::string::npos ? f : f.substr(slash + 8);
  }
  return "?";
}

}  // namespace

int main(int argc, char** argv) {
  std::string robot = "talos_reduced";
  int threads = 128, top = 25, only_pass = -1;
  bool by_wavefronts = false;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--robot" && a + 1 < argc) robot = argv[++a];
    else if (arg == "--threads" && a + 1 < argc) threads = std::atoi(argv[++a]);
    else if (arg == "--top" && a + 1 < argc) top = std::atoi(argv[++a]);
    else if (arg == "--pass" && a + 1 < argc) only_pass = std::atoi(argv[++a]);
    else if (arg == "--by-wavefronts") by_wavefronts = true;
    else {
      std::fprintf(stderr, "usage: cuda_shared_wavefronts [--robot talos_reduced|iiwa14] [--threads N] [--top N] [--pass P] [--by-wavefronts]\n");
      return 2;
    }
  }
  if (threads < 1 || threads > 1024) {
    std::fprintf(stderr, "--threads: 1 to 1024\n");
    return 2;
  }
  rbdgrad::Model model;
  if (!rbdgrad::load_urdf_string(std::string(rbdgrad::embedded_robot_urdf(robot)), robot, model).is_ok()) {
    std::fprintf(stderr, "no embedded robot %s\n", robot.c_str());
    return 2;
  }
  bool ok = false;
  if (robot == "talos_reduced" && model.nv == 32 && model.max_depth() == 10) ok = trace_state<32, 10>(model, threads);
  else if (robot == "iiwa14" && model.nv == 7 && model.max_depth() == 7) ok = trace_state<7, 7>(model, threads);
  else {
    std::fprintf(stderr, "%s: not one of the robots this tool is built for (talos_reduced, iiwa14)\n", robot.c_str());
    return 2;
  }
  if (!ok) return 1;

  const shared_trace::SourceSites sources = shared_trace::source_sites(shared_trace::recorder.sites());
  if (sources.same.empty()) std::fprintf(stderr, "warning: no source lines (addr2line); each copy of a site counted apart\n");
  const std::vector<shared_trace::Instruction> instructions = shared_trace::recorder.instructions(sources.same);
  struct Sum {
    long instructions = 0, wavefronts = 0, ideal = 0;
  };
  std::map<int, Sum> by_pass;
  std::map<const void*, Sum> by_site;
  Sum total, own;
  for (const auto& i : instructions) {
    const shared_trace::Wavefronts f = shared_trace::wavefronts(i.lanes);
    if (i.own) {
      ++own.instructions;
      own.wavefronts += f.actual;
      own.ideal += f.ideal;
    }
    for (Sum* s : {&by_pass[i.pass], &total}) {
      ++s->instructions;
      s->wavefronts += f.actual;
      s->ideal += f.ideal;
    }
    if (only_pass < 0 || i.pass == only_pass) {
      Sum& s = by_site[i.site];
      ++s.instructions;
      s.wavefronts += f.actual;
      s.ideal += f.ideal;
    }
  }
  std::printf("%s, one f64 state from tau (d qdd/d q, d qdd/d qd), %d threads: %ld warp instructions that "
              "access shared memory, %ld wavefronts (ideal %ld)\n",
              robot.c_str(), threads, total.instructions, total.wavefronts, total.ideal);
  // what keeping values in registers could take off with the items mapped as they are
  std::printf("of them loads of values their own thread stored (every lane): %ld instructions, %ld wavefronts "
              "(ideal %ld)\n\n",
              own.instructions, own.wavefronts, own.ideal);
  std::printf("| pass | instructions | wavefronts | ideal | excess |\n|---:|---:|---:|---:|---:|\n");
  for (const auto& [pass, s] : by_pass)
    std::printf("| %d | %ld | %ld | %ld | %ld |\n", pass, s.instructions, s.wavefronts, s.ideal, s.wavefronts - s.ideal);
  // the sites by their excess (bank conflicts), several sites of one source line summed
  std::map<std::string, Sum> by_line;
  for (const auto& [site, s] : by_site) {
    const auto f = sources.frames.find(site);
    Sum& l = by_line[f == sources.frames.end() ? "?" : source_line(f->second)];
    l.instructions += s.instructions;
    l.wavefronts += s.wavefronts;
    l.ideal += s.ideal;
  }
  std::vector<std::pair<std::string, Sum>> lines(by_line.begin(), by_line.end());
  std::sort(lines.begin(), lines.end(), [&](const auto& x, const auto& y) {
    if (by_wavefronts) return x.second.wavefronts > y.second.wavefronts;
    return x.second.wavefronts - x.second.ideal > y.second.wavefronts - y.second.ideal;
  });
  if (only_pass >= 0) std::printf("\npass %d's source lines:\n", only_pass);
  std::printf("\n| source line | instructions | wavefronts | ideal | excess |\n|---|---:|---:|---:|---:|\n");
  for (std::size_t k = 0; k < lines.size() && static_cast<int>(k) < top; ++k) {
    const Sum& s = lines[k].second;
    std::printf("| %s | %ld | %ld | %ld | %ld |\n", lines[k].first.c_str(), s.instructions, s.wavefronts, s.ideal,
                s.wavefronts - s.ideal);
  }
  return 0;
}
