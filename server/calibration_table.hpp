// The scheduler's latency models, one per (backend, model, precision), with where each came from,
// and their file: saved after a calibration and read at the next start, where an entry is reused
// only if its fingerprint (the backend's hardware and plugin, the model's content) is unchanged.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "latency_model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

struct CalibrationEntry {
  std::string backend;         // "cpu", "cuda", "fpga"
  std::string model;           // the served model's name
  std::uint32_t precision = 0;  // one rbdgrad_precision flag
  // what the entry is valid for (calibration.hpp: backend_fingerprint and model_fingerprint);
  // a file's entry with another fingerprint is ignored
  std::string fingerprint;
  // "measured 2026-12-02T08:30:00Z", "the plugin's own model (estimate_latency)"
  std::string source;
  LatencyModel latency;
};

class CalibrationTable {
 public:
  /// The entry of (backend, model, precision), or null.
  const CalibrationEntry* find(const std::string& backend, const std::string& model, std::uint32_t precision) const;
  /// Adds `entry`, replacing one of the same (backend, model, precision).
  void set(CalibrationEntry entry);
  const std::vector<CalibrationEntry>& entries() const noexcept { return entries_; }

  /// Writes the table as YAML to `path` (atomically: a temporary file renamed over it), creating
  /// its directory. Errors: unavailable naming the path.
  Status save(const std::string& path) const;
  /// Reads a file save() wrote. A missing file is not_found; anything else that is not such a
  /// file is invalid_argument naming the path and the problem. Entries with an empty model are
  /// dropped.
  static Status load(const std::string& path, CalibrationTable& out);

 private:
  std::vector<CalibrationEntry> entries_;
};

}  // namespace rbdgrad::server
