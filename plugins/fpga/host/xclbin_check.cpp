#include "host/xclbin_check.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

#include "xclbin.h"  // XRT's description of the format (axlf)

namespace rbdgrad::fpga {
namespace {

template <class T>
T read_at(const std::vector<char>& data, std::size_t offset) {
  T value;
  std::memcpy(&value, data.data() + offset, sizeof(T));
  return value;
}

// an array section whose leading int32 count must fit what follows its header
bool count_fits(const std::vector<char>& data, const axlf_section_header& h, std::size_t head, std::size_t element) {
  if (h.m_sectionSize < head) return false;
  const auto count = read_at<std::int32_t>(data, h.m_sectionOffset);
  return count >= 0 && static_cast<std::uint64_t>(count) <= (h.m_sectionSize - head) / element;
}

std::string check(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return "cannot be read";
  const std::vector<char> data((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (data.size() < sizeof(axlf)) return "is " + std::to_string(data.size()) + " bytes, shorter than an xclbin header";
  const auto top = read_at<axlf>(data, 0);
  if (std::memcmp(top.m_magic, "xclbin2", 8) != 0) return "is not an xclbin (no 'xclbin2' magic)";
  if (top.m_header.m_length != data.size())
    return "says it is " + std::to_string(top.m_header.m_length) + " bytes long but is " +
           std::to_string(data.size()) + " (truncated?)";
  const std::uint64_t sections = top.m_header.m_numSections;
  const std::size_t table = offsetof(axlf, m_sections);
  if (sections == 0 || sections > (data.size() - table) / sizeof(axlf_section_header))
    return "has a section table that does not fit the file (" + std::to_string(sections) + " sections)";
  std::uint32_t seen = 0;
  for (std::uint64_t i = 0; i < sections; ++i) {
    const auto h = read_at<axlf_section_header>(data, table + i * sizeof(axlf_section_header));
    if (h.m_sectionOffset > data.size() || h.m_sectionSize > data.size() - h.m_sectionOffset)
      return "has section " + std::to_string(i) + " outside the file";
    if (h.m_sectionKind < 32) seen |= 1u << h.m_sectionKind;
    if ((h.m_sectionKind == MEM_TOPOLOGY && !count_fits(data, h, offsetof(mem_topology, m_mem_data), sizeof(mem_data))) ||
        (h.m_sectionKind == IP_LAYOUT && !count_fits(data, h, offsetof(ip_layout, m_ip_data), sizeof(ip_data))) ||
        (h.m_sectionKind == CONNECTIVITY &&
         !count_fits(data, h, offsetof(connectivity, m_connection), sizeof(connection))))
      return "has section " + std::to_string(i) + " (kind " + std::to_string(h.m_sectionKind) +
             ") whose entry count does not fit it";
  }
  const std::pair<int, const char*> needed[] = {{EMBEDDED_METADATA, "EMBEDDED_METADATA (the kernel's description)"},
                                                {IP_LAYOUT, "IP_LAYOUT (its compute units)"},
                                                {CONNECTIVITY, "CONNECTIVITY"},
                                                {MEM_TOPOLOGY, "MEM_TOPOLOGY"}};
  for (const auto& [kind, name] : needed)
    if ((seen & (1u << kind)) == 0) return std::string("has no ") + name + " section";
  return "";
}

}  // namespace

Status check_xclbin_file(const std::string& path) {
  const std::string problem = check(path);
  if (problem.empty()) return Status::ok();
  return invalid_argument("xclbin '" + path + "' " + problem);
}

}  // namespace rbdgrad::fpga
