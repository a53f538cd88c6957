#include "calibration_table.hpp"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

#include "backend_pool.hpp"

namespace rbdgrad::server {

namespace {

constexpr int kFileVersion = 1;

std::uint32_t precision_from_label(const std::string& label) {
  if (label == "f64") return RBDGRAD_PRECISION_F64;
  if (label == "f32") return RBDGRAD_PRECISION_F32;
  if (label == "fixed") return RBDGRAD_PRECISION_FIXED_Q16_16;
  return 0;
}

}  // namespace

const CalibrationEntry* CalibrationTable::find(const std::string& backend, const std::string& model,
                                               std::uint32_t precision) const {
  for (const CalibrationEntry& e : entries_)
    if (e.backend == backend && e.model == model && e.precision == precision) return &e;
  return nullptr;
}

void CalibrationTable::set(CalibrationEntry entry) {
  for (CalibrationEntry& e : entries_) {
    if (e.backend == entry.backend && e.model == entry.model && e.precision == entry.precision) {
      e = std::move(entry);
      return;
    }
  }
  entries_.push_back(std::move(entry));
}

Status CalibrationTable::save(const std::string& path) const {
  YAML::Emitter out;
  out.SetDoublePrecision(6);
  out << YAML::BeginMap << YAML::Key << "rbdgrad_calibration" << YAML::Value << kFileVersion;
  out << YAML::Key << "entries" << YAML::Value << YAML::BeginSeq;
  for (const CalibrationEntry& e : entries_) {
    out << YAML::BeginMap;
    out << YAML::Key << "backend" << YAML::Value << e.backend;
    out << YAML::Key << "model" << YAML::Value << e.model;
    out << YAML::Key << "precision" << YAML::Value << precision_label(e.precision);
    out << YAML::Key << "fingerprint" << YAML::Value << e.fingerprint;
    out << YAML::Key << "source" << YAML::Value << e.source;
    out << YAML::Key << "points" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const LatencyModel::Point& p : e.latency.points())
      out << YAML::Flow << YAML::BeginSeq << p.n << p.us << YAML::EndSeq;
    out << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  if (!out.good()) return unavailable("calibration file " + path + ": " + out.GetLastError());

  std::error_code ec;
  const std::filesystem::path file(path);
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), ec);
  if (ec) return unavailable("calibration file " + path + ": cannot create its directory: " + ec.message());
  const std::string tmp = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream f(tmp, std::ios::trunc);
    f << "# rbdgradd's measured batch times (us) per backend, model and precision: the scheduler's\n"
         "# latency models. Rewritten by the daemon; an entry is reused while its fingerprint holds.\n"
      << out.c_str() << "\n";
    if (!f.flush()) {
      std::filesystem::remove(tmp, ec);
      return unavailable("calibration file " + path + ": cannot write " + tmp);
    }
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return unavailable("calibration file " + path + ": cannot replace it: " + ec.message());
  }
  return Status::ok();
}

Status CalibrationTable::load(const std::string& path, CalibrationTable& out) {
  std::ifstream f(path);
  if (!f) return not_found("calibration file " + path + " does not exist or cannot be read");
  std::stringstream text;
  text << f.rdbuf();
  const auto bad = [&](const std::string& why) { return invalid_argument("calibration file " + path + ": " + why); };
  CalibrationTable table;
  try {
    const YAML::Node root = YAML::Load(text.str());
    if (!root.IsMap() || !root["rbdgrad_calibration"]) return bad("not an rbdgrad calibration file");
    if (root["rbdgrad_calibration"].as<int>() != kFileVersion)
      return bad("version " + root["rbdgrad_calibration"].as<std::string>() + ", expected " +
                 std::to_string(kFileVersion));
    const YAML::Node entries = root["entries"];
    if (entries && !entries.IsSequence()) return bad("'entries' is not a list");
    for (std::size_t i = 0; entries && i < entries.size(); ++i) {
      const YAML::Node n = entries[i];
      const std::string where = "entry " + std::to_string(i) + " (line " + std::to_string(n.Mark().line + 1) + ")";
      if (!n.IsMap()) return bad(where + " is not a map");
      CalibrationEntry e;
      e.backend = n["backend"].as<std::string>("");
      e.model = n["model"].as<std::string>("");
      e.precision = precision_from_label(n["precision"].as<std::string>(""));
      e.fingerprint = n["fingerprint"].as<std::string>("");
      e.source = n["source"].as<std::string>("");
      if (e.backend.empty() || e.model.empty()) continue;
      if (e.precision == 0) return bad(where + ": unknown precision '" + n["precision"].as<std::string>("") + "'");
      std::vector<LatencyModel::Point> points;
      const YAML::Node pts = n["points"];
      if (!pts || !pts.IsSequence()) return bad(where + ": no 'points' list");
      for (const YAML::Node& p : pts) {
        if (!p.IsSequence() || p.size() != 2) return bad(where + ": a point is not [n, us]");
        points.push_back({p[0].as<std::uint64_t>(), p[1].as<double>()});
      }
      e.latency = LatencyModel(std::move(points));
      table.set(std::move(e));
    }
  } catch (const YAML::Exception& ex) {
    return bad(ex.what());
  }
  out = std::move(table);
  return Status::ok();
}

}  // namespace rbdgrad::server
