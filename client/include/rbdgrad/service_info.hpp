// What the rbdgrad service says about itself: the models it serves (Client::list_models,
// Client::get_model) and its version, backends and limits (Client::server_info).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rbdgrad/compute_types.hpp"

namespace rbdgrad {

// One entry of Client::list_models.
struct ServedModel {
  std::string name;    // the name requests use
  int nv = 0;          // number of moving joints
  std::string source;  // URDF path on the server, or "<embedded>"
};

// One moving joint, in the model's joint order.
struct JointDescription {
  std::string name;
  std::string type;         // "revolute", "continuous" or "prismatic"
  int parent = -1;          // index of the parent joint, -1 for the fixed root
  std::string parent_link;  // URDF links
  std::string child_link;
  double lower_limit = 0;   // rad or m; both 0 when the URDF gives none
  double upper_limit = 0;
  double effort_limit = 0;  // N m or N; 0 when unknown
  double velocity_limit = 0;

  // True when the URDF gives a position range (lower < upper).
  bool has_position_limits() const noexcept { return lower_limit < upper_limit; }
};

// Client::get_model.
struct ModelDescription {
  std::string name;
  int nv = 0;
  std::vector<JointDescription> joints;  // (nv) in the model's joint order (the arrays' order)
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  // world frame, m/s^2
  std::string summary;                   // human-readable, several lines
};

// Client::get_scene, Client::list_scenes: a model the server reduced for one fixed problem.
struct SceneDescription {
  std::string name;
  std::string model;                                         // the model it is made from
  int nv = 0;                                                // the scene's joints
  std::vector<JointDescription> joints;                      // (nv) in the order of its arrays
  std::vector<std::pair<std::string, double>> locked_joints;  // the model's joints held, and where
  bool gravity = true;                                       // false: computed without gravity
  std::vector<std::string> force_links;  // the links that take external forces, in fext's order
  std::uint32_t outputs = 0;             // Output bits: what it computes
  bool minv_supplied = false;            // true: each request brings M^-1 (minv)
};

// Client::register_scene: a scene to register while the server runs, defined as one of its
// configuration's `scenes` entries.
struct SceneDefinition {
  std::string name;   // unique among the server's models and scenes; required
  std::string model;  // a model the server serves (Client::list_models); required
  std::vector<std::pair<std::string, double>> locked_joints;  // the model's joints to hold, and where (rad or m)
  bool gravity = true;                   // false: computed without gravity
  std::vector<std::string> force_links;  // the links that take external forces, in fext's order
  std::uint32_t outputs = 0;             // Output bits: what it computes; 0 = kDqddDq | kDqddDqd
  bool minv_supplied = false;            // true: each request brings M^-1 (minv)
};

// One latency model of the server's scheduler: a backend's time per batch for one model and
// precision, interpolated between its points.
struct LatencyModelStatus {
  std::string model;
  Precision precision = Precision::kAuto;
  std::string source;        // "measured 2026-12-02T08:30:00Z", "the plugin's own model (...)"
  double fixed_us = 0;       // predicted time of one state
  double per_state_us = 0;   // the rate per state beyond the last point
  std::vector<std::uint64_t> n;  // the points: batch sizes ...
  std::vector<double> us;        // ... and microseconds per batch
};

// What one backend's instances of one model have to do at the moment of the call.
struct QueueStatus {
  std::string model;
  std::uint32_t queued = 0;   // requests waiting for an instance
  std::uint32_t running = 0;  // instances computing
  double pending_us = 0;      // the predicted compute time of those requests
};

// Where requests without a backend hint go, for one model: from each crossover's N on, its backend
// is predicted fastest (each in its best precision).
struct RoutingStatus {
  std::string model;
  std::vector<std::pair<std::uint64_t, std::string>> crossovers;  // (from N, backend name)
  std::int64_t small_n = -1;  // the threshold policy's limits; -1 = does not apply
  std::int64_t large_n = -1;
};

// One backend of the server, ready or not.
struct BackendStatus {
  Backend backend = Backend::kAuto;   // kCpu, kCuda, kFpga; kAuto for one the client does not know
  std::string name;                   // "cpu", ...
  bool ready = false;
  std::string reason;                 // why it is unavailable, when not ready
  std::vector<Precision> precisions;  // what it computes in
  std::uint64_t max_batch = 0;        // largest N per computation; 0 = no limit
  std::string mode;                   // "" as itself; "csim": the FPGA kernel's C simulation on the
                                      // server's CPU (the FPGA's arithmetic, not its speed)
  std::string device;                 // the device it runs on, when the backend names it
  std::string detail;                 // more on how it runs (e.g. which CUDA kernel), or ""
  std::vector<LatencyModelStatus> latency_models;
  std::vector<QueueStatus> queues;    // one per model it serves
};

// Client::server_info.
struct ServerInfo {
  std::string version;
  std::vector<BackendStatus> backends;
  std::uint32_t max_states_per_request = 0;
  std::uint64_t max_message_bytes = 0;
  std::uint32_t max_concurrent_requests = 0;
  std::string scheduler_policy;         // "cost" or "threshold"
  std::vector<RoutingStatus> routing;   // one per model
};

}  // namespace rbdgrad
