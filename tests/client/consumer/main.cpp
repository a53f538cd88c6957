// The consumer of the installed rbdgrad client: with no server at the address, every call must
// fail cleanly (UNAVAILABLE at once; DEADLINE_EXCEEDED when told to wait for the server).
#include <cstdio>
#include <string>
#include <vector>

#include <rbdgrad/client.hpp>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: rbdgrad_consumer HOST:PORT (an address where nothing listens)\n");
    return 2;
  }
  const std::vector<double> q(7, 0.1), qd(7, 0.0), tau(7, 1.0);
  rbdgrad::ComputeRequest req;
  req.model = "iiwa14";
  req.num_states = 1;
  req.outputs = rbdgrad::Output::kDqddDq | rbdgrad::Output::kDqddDqd;
  req.q = q;
  req.qd = qd;
  req.u = tau;

  int failures = 0;
  rbdgrad::Client client(argv[1]);
  try {
    (void)client.compute(req);
    std::printf("FAIL: compute succeeded without a server\n");
    ++failures;
  } catch (const rbdgrad::ClientError& e) {
    const bool ok = e.code() == rbdgrad::RpcCode::kUnavailable;
    std::printf("%s: compute: %s\n", ok ? "ok" : "FAIL", e.what());
    failures += !ok;
  }

  rbdgrad::ClientOptions waiting;
  waiting.wait_for_ready = true;
  waiting.default_timeout = std::chrono::milliseconds(200);
  rbdgrad::ComputeResult result;
  const rbdgrad::RpcStatus st = rbdgrad::Client(argv[1], waiting).compute(req, result);
  const bool ok = st.code() == rbdgrad::RpcCode::kDeadlineExceeded && !result.valid();
  std::printf("%s: compute with wait_for_ready: %s\n", ok ? "ok" : "FAIL", st.to_string().c_str());
  failures += !ok;
  return failures == 0 ? 0 : 1;
}
