#include "host/axi_packing.hpp"

#include <cmath>

#include "kernel/gradient_kernel.hpp"
#include "kernel/robot_constants.hpp"
#include "rbdgrad/fixed_point.hpp"

namespace rbdgrad::fpga {
namespace {

using DeviceScalar = Q16_16;

}  // namespace

bool to_device_word(double x, DeviceWord& out) {
  const FixedOverflowScope scope;
  out = DeviceScalar(x).raw();
  return !scope.overflowed();
}

bool pack_robot(const Model& model, std::vector<DeviceWord>& out, std::string& error) {
  RobotConstants<double, kDeviceMaxNv> robot;
  if (!robot_constants(model, robot)) {
    error = "the model has " + std::to_string(model.nv) + " joints, the FPGA kernel takes at most " +
            std::to_string(kDeviceMaxNv);
    return false;
  }
  out.assign(static_cast<std::size_t>(AxiLayout::robot_words(model.nv)), 0);
  std::size_t at = 0;
  out[at++] = model.nv;
  auto put = [&](double x, const char* what, int joint) {
    if (to_device_word(x, out[at++])) return true;
    error = std::string(what) + " of joint " + std::to_string(joint) + " (" + std::to_string(x) +
            ") is outside the FPGA format's range";
    return false;
  };
  for (int i = 0; i < model.nv; ++i) {
    out[at++] = robot.parent[i];
    out[at++] = robot.prismatic[i] ? 1 : 0;
    for (double x : robot.joint_rotation[i])
      if (!put(x, "the joint rotation", i)) return false;
    for (double x : robot.joint_translation[i])
      if (!put(x, "the joint translation", i)) return false;
    for (double x : robot.inertia[i])
      if (!put(x, "the spatial inertia", i)) return false;
  }
  for (double x : robot.gravity)
    if (!put(x, "gravity", -1)) return false;
  return true;
}

bool pack_state(int nv, const double* q, const double* qd, const double* u, const double* minv,
                std::vector<DeviceWord>& out, std::string& error) {
  std::vector<DeviceWord> words(static_cast<std::size_t>(AxiLayout::in_words(nv)));
  if (!pack_state(nv, q, qd, u, minv, words.data(), error)) return false;
  out.insert(out.end(), words.begin(), words.end());
  return true;
}

bool pack_state(int nv, const double* q, const double* qd, const double* u, const double* minv, DeviceWord* words,
                std::string& error) {
  const std::size_t n = static_cast<std::size_t>(nv);
  const double* fields[] = {q, nullptr, nullptr, qd, u};
  const char* names[] = {"q", "sin q", "cos q", "qd", "u"};
  for (std::size_t f = 0; f < 5; ++f)
    for (std::size_t i = 0; i < n; ++i) {
      const double x = f == 1 ? std::sin(q[i]) : f == 2 ? std::cos(q[i]) : fields[f][i];
      if (!to_device_word(x, words[f * n + i])) {
        error = std::string(names[f]) + "[" + std::to_string(i) + "] = " + std::to_string(x) +
                " is outside the FPGA format's range";
        return false;
      }
    }
  for (std::size_t e = 0; e < n * n; ++e)
    if (!to_device_word(minv[e], words[5 * n + e])) {
      error = "M^-1 element " + std::to_string(e) + " = " + std::to_string(minv[e]) +
              " is outside the FPGA format's range";
      return false;
    }
  return true;
}

bool unpack_state(int nv, const DeviceWord* words, double* qdd, double* dqdd_dq, double* dqdd_dqd) {
  const int n = nv;
  if (words[n + 2 * n * n] != kStatusOk) return false;
  auto value = [](DeviceWord w) { return DeviceScalar::from_raw(w).to_double(); };
  for (int i = 0; i < n; ++i) qdd[i] = value(words[i]);
  for (int e = 0; e < n * n; ++e) {
    dqdd_dq[e] = value(words[n + e]);
    dqdd_dqd[e] = value(words[n + n * n + e]);
  }
  return true;
}

}  // namespace rbdgrad::fpga
