// The host model of the block kernel's shared-memory banks (bench/plugins/shared_access_trace.hpp):
// the wavefronts of the access patterns whose cost is known, and the grouping of a pass's items
// into a warp's instructions.
#include <gtest/gtest.h>

#include <vector>

#include "shared_access_trace.hpp"

#include "device/scalar_pairs.hpp"

namespace rbdgrad::testing {
namespace {

using shared_trace::Access;
using shared_trace::Traced;

// lane l accesses `bytes` at offset(l), in scalars of 8 bytes
template <class Offset>
shared_trace::Wavefronts lanes_at(int lanes, int bytes, Offset offset) {
  std::vector<std::pair<int, Access>> v;
  for (int l = 0; l < lanes; ++l)
    v.emplace_back(l, Access{nullptr, 0, static_cast<std::uint32_t>(8 * offset(l)), static_cast<std::uint8_t>(bytes), false});
  return shared_trace::wavefronts(v);
}

TEST(SharedAccessTrace, WavefrontsOfKnownPatterns) {
  // a broadcast: one word for the warp
  EXPECT_EQ(lanes_at(32, 8, [](int) { return 5; }).actual, 1);
  // consecutive doubles: 256 bytes, two wavefronts, no conflict
  auto f = lanes_at(32, 8, [](int l) { return l; });
  EXPECT_EQ(f.actual, 2);
  EXPECT_EQ(f.ideal, 2);
  // stride 2 doubles: half the banks, twice the words each
  f = lanes_at(32, 8, [](int l) { return 2 * l; });
  EXPECT_EQ(f.actual, 4);
  EXPECT_EQ(f.ideal, 2);
  // an odd stride is free of conflicts
  EXPECT_EQ(lanes_at(32, 8, [](int l) { return 7 * l; }).actual, 2);
  // consecutive pairs (16 bytes a lane): four wavefronts
  EXPECT_EQ(lanes_at(32, 16, [](int l) { return 2 * l; }).actual, 4);
  // three lanes a body of 6-vectors, component l % 3 (the lean passes' items): bodies 8 apart
  // share banks, three words in the busiest bank where two would do
  f = lanes_at(32, 8, [](int l) { return 6 * (l / 3) + l % 3; });
  EXPECT_EQ(f.actual, 3);
  EXPECT_EQ(f.ideal, 2);
}

// A pass of 64 items on 64 threads (two warps), each item loading its element and storing it
// doubled: each warp one load and one store instruction; a pair read as one 16-byte access; a
// load of what the same thread stored is its own value
TEST(SharedAccessTrace, ItemsBecomeWarpInstructions) {
  std::vector<Traced> shared(160, Traced(1.0));
  auto& r = shared_trace::recorder;
  r.watch(shared.data(), shared.size() * sizeof(Traced), 64);
  cuda::ThreadGroup g;
  g.size = 64;
  g.trace = &r;
  g.for_each(64, [&](int t) {
    const Traced x = shared[t];
    shared[64 + t] = x + x;
  });
  g.sync();
  g.for_each(32, [&](int t) {
    Traced a, b;
    cuda::load_pair(shared.data() + 128, a, b);  // every lane the same pair: a broadcast
    shared[t] = a * b;
  });
  g.sync();
  // threads 0..31 read back what they stored in the first pass: loads of their own values
  g.for_each(32, [&](int t) {
    const Traced y = shared[64 + t];
    EXPECT_EQ(y.v, 2.0);
  });
  // (the host compiler's copies of a site made one, as the tool does)
  const std::vector<shared_trace::Instruction> is = r.instructions(shared_trace::source_sites(r.sites()).same);
  ASSERT_EQ(is.size(), 7u);
  int loads = 0, stores = 0, total = 0, own = 0;
  for (const auto& i : is) {
    (i.store ? stores : loads)++;
    own += i.own ? 1 : 0;
    if (i.own) {
      EXPECT_EQ(i.pass, 2);
    }
    total += shared_trace::wavefronts(i.lanes).actual;
    EXPECT_EQ(i.lanes.size(), 32u);
    if (i.pass == 1) {
      EXPECT_EQ(i.warp, 0);
    }
  }
  EXPECT_EQ(loads, 4);
  EXPECT_EQ(stores, 3);
  EXPECT_EQ(own, 1);  // the last pass's load; the first pass's read what no thread stored
  // pass 0: 2 + 2 a warp; pass 1: the pair a broadcast (1), the store 2; pass 2: 2
  EXPECT_EQ(total, 13);
  // a value out of the watched range (a local) is not an access
  Traced local(2.0);
  const Traced copy = local;
  EXPECT_EQ(r.instructions(shared_trace::source_sites(r.sites()).same).size(), 7u);
  EXPECT_EQ(copy.v, 2.0);
}

}  // namespace
}  // namespace rbdgrad::testing
