// Tests for tools/cli/compute_batches.cpp and compute_states.cpp (`rbdgrad compute`): requests
// under the server's limits, one input kind per request, per-state errors isolated, against the
// fake Dynamics service of the client tests.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "compute_batches.hpp"
#include "compute_states.hpp"
#include "fake_dynamics_service.hpp"

namespace rbdgrad::cli {
namespace {

constexpr int kNv = 3;

InputState make_state(long index, ComputeInput input) {
  InputState s;
  s.index = index;
  s.kind = "test";
  s.input = input;
  for (int i = 0; i < kNv; ++i) {
    s.q.push_back(0.1 * static_cast<double>(index) + i);
    s.qd.push_back(-0.2 * i);
    s.u.push_back(static_cast<double>(index));
  }
  return s;
}

BatchPlan plan(std::uint32_t max_states) {
  BatchPlan p;
  p.model = "iiwa14";
  p.outputs = Output::kQdd | Output::kDqddDq;
  p.nv = kNv;
  p.max_states_per_request = max_states;
  p.max_message_bytes = 1 << 20;
  return p;
}

// state s's qdd from the fake's rule
double expected_qdd(const InputState& s, int i) {
  return rbdgrad::testing::fake_output_value(v1::OUTPUT_QDD, s.q.data(), s.qd.data(), s.u.data(), i, 0);
}

TEST(ComputeBatches, ChunksFollowTheLimitAndTheInputKind) {
  rbdgrad::testing::FakeServer server;
  const Client client(server.address());
  std::vector<InputState> states;
  for (long k = 0; k < 5; ++k) states.push_back(make_state(k, ComputeInput::kTau));
  for (long k = 5; k < 7; ++k) states.push_back(make_state(k, ComputeInput::kQdd));
  ComputedStates out;
  ASSERT_TRUE(compute_in_batches(client, plan(2), states, out));
  // tau: 2 + 2 + 1, qdd: 2
  const auto received = server.service().received();
  ASSERT_EQ(received.size(), 4u);
  EXPECT_EQ(out.requests, 4u);
  EXPECT_EQ(received[2].num_states(), 1u);
  EXPECT_EQ(received[2].input_kind(), v1::INPUT_KIND_TAU);
  EXPECT_EQ(received[3].input_kind(), v1::INPUT_KIND_QDD);
  for (std::size_t s = 0; s < states.size(); ++s) {
    const ComputedStates::Slot& slot = out.slots[s];
    ASSERT_GE(slot.result, 0) << slot.error;
    const ComputeResult& r = out.results[static_cast<std::size_t>(slot.result)];
    for (int i = 0; i < kNv; ++i) EXPECT_EQ(r.qdd(slot.k)(i), expected_qdd(states[s], i)) << "state " << s;
  }
  EXPECT_EQ(out.sum.queue_us, 4 * rbdgrad::testing::kQueueUs);
}

TEST(ComputeBatches, ARefusedStateGetsTheErrorAndTheOthersAreComputed) {
  rbdgrad::testing::FakeServer server;
  const Client client(server.address());
  std::vector<InputState> states;
  for (long k = 0; k < 4; ++k) states.push_back(make_state(k, ComputeInput::kTau));
  states[2].q[1] = std::numeric_limits<double>::quiet_NaN();  // the server refuses it
  states[3].error = "state 3: field 'q' has 2 values, expected 3";  // refused before sending
  states[3].q.clear();
  ComputedStates out;
  ASSERT_TRUE(compute_in_batches(client, plan(0), states, out));
  EXPECT_GE(out.slots[0].result, 0);
  EXPECT_GE(out.slots[1].result, 0);
  EXPECT_EQ(out.slots[2].result, -1);
  EXPECT_EQ(out.slots[2].error, "state 2: INVALID_ARGUMENT: state 0: field 'q' element 1 is not finite (nan)");
  EXPECT_EQ(out.slots[3].error, "state 3: field 'q' has 2 values, expected 3");
  // one request of 3, then one per state
  EXPECT_EQ(out.requests, 4u);
  const ComputeResult& r1 = out.results[static_cast<std::size_t>(out.slots[1].result)];
  EXPECT_EQ(r1.qdd(out.slots[1].k)(2), expected_qdd(states[1], 2));
}

TEST(ComputeBatches, ACallFailureStopsTheRun) {
  rbdgrad::testing::FakeServer server;
  const Client client(server.address());
  std::vector<InputState> states = {make_state(0, ComputeInput::kTau)};
  BatchPlan p = plan(0);
  p.model = "unknown";
  ComputedStates out;
  const RpcStatus st = compute_in_batches(client, p, states, out);
  EXPECT_EQ(st.code(), RpcCode::kNotFound);
  EXPECT_EQ(st.message(), rbdgrad::testing::kUnknownMessage);
}

TEST(ComputeBatches, TheMessageLimitBoundsTheStatesPerRequest) {
  BatchPlan p = plan(0);
  p.outputs = mask(Output::kDqddDq);
  p.nv = 10;
  p.max_message_bytes = 10000;  // 801 bytes per state: 8000 / 801
  EXPECT_EQ(states_per_request(p), 9u);
  p.max_states_per_request = 4;
  EXPECT_EQ(states_per_request(p), 4u);
  p.max_message_bytes = 10;
  EXPECT_EQ(states_per_request(p), 1u) << "at least one";
}

TEST(ComputeStates, RandomStatesAreSeededAndWithinTheLimits) {
  ModelDescription model;
  model.nv = 2;
  model.joints.resize(2);
  model.joints[0] = {"a", "revolute", -1, "", "", -0.5, 0.25, 40, 1};
  model.joints[1] = {"b", "continuous", 0, "", "", 0, 0, 0, 0};
  const std::vector<InputState> a = random_states(model, 200, 7, ComputeInput::kTau);
  const std::vector<InputState> b = random_states(model, 200, 7, ComputeInput::kTau);
  const std::vector<InputState> c = random_states(model, 200, 8, ComputeInput::kQdd);
  ASSERT_EQ(a.size(), 200u);
  EXPECT_EQ(a[17].q, b[17].q);
  EXPECT_NE(a[17].q, c[17].q);
  for (const InputState& s : a) {
    EXPECT_GE(s.q[0], -0.5);
    EXPECT_LE(s.q[0], 0.25);
    EXPECT_LE(std::abs(s.q[1]), 3.1416);
    EXPECT_LE(std::abs(s.u[0]), 20.0) << "half the effort limit";
    EXPECT_LE(std::abs(s.u[1]), 10.0);
    EXPECT_LE(std::abs(s.qd[1]), 1.0);
    EXPECT_EQ(s.input, ComputeInput::kTau);
  }
  EXPECT_EQ(c[0].input, ComputeInput::kQdd);
}

TEST(ComputeStates, FileStatesReadTauElseQddAndKeepEvalsErrors) {
  io::StateFile file;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  file.states.push_back({0, "a", 2, {{"q", {1, 2}}, {"qd", {3, 4}}, {"tau", {5, 6}}, {"qdd", {7, 8}}}});
  file.states.push_back({1, "b", 3, {{"q", {1, 2}}, {"qd", {3, 4}}, {"qdd", {7, 8}}}});
  file.states.push_back({2, "c", 4, {{"q", {1, 2}}, {"qd", {3, nan}}, {"tau", {5, 6}}}});
  std::vector<InputState> s = file_states(file, 2, nullptr);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].input, ComputeInput::kTau);
  EXPECT_EQ(s[0].u, (std::vector<double>{5, 6}));
  EXPECT_EQ(s[1].input, ComputeInput::kQdd);
  EXPECT_EQ(s[1].u, (std::vector<double>{7, 8}));
  EXPECT_EQ(s[2].error, "state 2: field 'qd' element 1 is not finite (nan)");
  // --input qdd: state 0's qdd is the input; state 2 has none
  const ComputeInput qdd = ComputeInput::kQdd;
  s = file_states(file, 2, &qdd);
  EXPECT_EQ(s[0].input, ComputeInput::kQdd);
  EXPECT_EQ(s[0].u, (std::vector<double>{7, 8}));
  EXPECT_NE(s[2].error.find("qd"), std::string::npos) << s[2].error;
}

}  // namespace
}  // namespace rbdgrad::cli
