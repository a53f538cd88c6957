// State files (JSON Lines): reader (nlohmann::json, after a pre-scan for non-finite tokens) and a fast writer.
#include "rbdgrad/io/state_file.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <istream>
#include <limits>
#include <ostream>
#include <stdexcept>

namespace rbdgrad::io {
namespace {

// ordered_json keeps the file's key order, so the first bad field in the line is the one reported.
using Json = nlohmann::ordered_json;

// ---------------------------------------------------------------------------------------------------
// Non-finite tokens. nlohmann rejects NaN / Infinity, so before parsing, every such token outside of string
// literals is replaced by a JSON string holding a sentinel (a value no real file holds: it starts with U+0001).
// Those sentinels are only interpreted on lines where a replacement was made.

enum class NonFinite : unsigned char { kNaN, kPosInf, kNegInf };

struct Token {
  std::string_view text;
  NonFinite kind;
};
// Longest spellings first where one is a prefix of another ("-Infinity" before "-inf", "Infinity" before "inf").
constexpr Token kTokens[] = {
    {"-Infinity", NonFinite::kNegInf}, {"-infinity", NonFinite::kNegInf}, {"Infinity", NonFinite::kPosInf},
    {"infinity", NonFinite::kPosInf},  {"-NaN", NonFinite::kNaN},         {"-nan", NonFinite::kNaN},
    {"NaN", NonFinite::kNaN},          {"nan", NonFinite::kNaN},          {"-inf", NonFinite::kNegInf},
    {"inf", NonFinite::kPosInf},
};

// JSON text inserted in place of a token, and the string value it decodes to.
constexpr std::string_view kSentinelText[] = {"\"\\u0001nan\"", "\"\\u0001+inf\"", "\"\\u0001-inf\""};
constexpr std::string_view kSentinelValue[] = {"\x01nan", "\x01+inf", "\x01-inf"};

struct Replacement {
  std::size_t orig_pos, orig_len, new_pos, new_len;
};

bool is_ident_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.';
}

bool is_number_char(char c) { return (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.' || c == 'e' || c == 'E'; }

// Copies `in` to `out` with non-finite tokens (outside string literals) replaced by sentinel strings; with
// `overflowing_numbers`, also numbers too large for a double (1e999, which Python reads as inf; nlohmann
// rejects them, so this slower pass only runs after such a rejection).
// Returns false, leaving `out` untouched, when there was nothing to replace.
bool replace_nonfinite_tokens(std::string_view in, std::string& out, std::vector<Replacement>& reps,
                              bool overflowing_numbers) {
  reps.clear();
  bool in_string = false;
  std::size_t copied = 0;  // in[0, copied) is already in `out`
  for (std::size_t i = 0; i < in.size(); ++i) {
    const char c = in[i];
    if (in_string) {
      if (c == '\\') {
        ++i;  // skip the escaped character (\" in particular)
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
      continue;
    }
    const auto replace = [&](std::size_t len, NonFinite kind) {
      if (reps.empty()) {
        out.clear();
        out.reserve(in.size() + 64);
      }
      out.append(in.substr(copied, i - copied));
      const std::string_view s = kSentinelText[static_cast<int>(kind)];
      reps.push_back({i, len, out.size(), s.size()});
      out.append(s);
      copied = i + len;
      i += len - 1;
    };
    if (overflowing_numbers && ((c >= '0' && c <= '9') || (c == '-' && i + 1 < in.size() && in[i + 1] >= '0' &&
                                                            in[i + 1] <= '9'))) {
      std::size_t end = i + 1;
      while (end < in.size() && is_number_char(in[end])) ++end;
      const std::string token(in.substr(i, end - i));
      const double v = std::strtod(token.c_str(), nullptr);
      if (std::isinf(v)) {
        replace(end - i, v > 0 ? NonFinite::kPosInf : NonFinite::kNegInf);
      } else {
        i = end - 1;
      }
      continue;
    }
    if (c != 'N' && c != 'n' && c != 'I' && c != 'i' && c != '-') continue;
    for (const Token& t : kTokens) {
      const std::size_t end = i + t.text.size();
      if (in.compare(i, t.text.size(), t.text) != 0) continue;
      if (end < in.size() && is_ident_char(in[end])) continue;  // "info", "NaNa": leave for the parser to reject
      replace(t.text.size(), t.kind);
      break;
    }
  }
  if (reps.empty()) return false;
  out.append(in.substr(copied));
  return true;
}

// Maps a 1-based byte column of the rewritten line back to the original line.
std::size_t original_column(std::size_t col, const std::vector<Replacement>& reps) {
  const std::size_t p = col == 0 ? 0 : col - 1;
  std::size_t removed = 0, added = 0;
  for (const Replacement& r : reps) {
    if (p >= r.new_pos + r.new_len) {
      added += r.new_len;
      removed += r.orig_len;
    } else if (p >= r.new_pos) {
      return r.orig_pos + 1;
    } else {
      break;
    }
  }
  return p + removed - added + 1;
}

// Puts readable spellings back for the sentinels in a parser message ("last read: '...'").
std::string without_sentinels(std::string m) {
  constexpr std::string_view kReadable[] = {"NaN", "Infinity", "-Infinity"};
  for (int k = 0; k < 3; ++k) {
    for (std::size_t p = m.find(kSentinelText[k]); p != std::string::npos; p = m.find(kSentinelText[k], p))
      m.replace(p, kSentinelText[k].size(), kReadable[k]);
  }
  return m;
}

// ---------------------------------------------------------------------------------------------------
// Parsing helpers.

struct LineParser {
  std::string rewritten;
  std::vector<Replacement> reps;
  bool had_sentinels = false;

  // Parses one line; on failure fills `detail` (" at column 17: syntax error ...").
  bool parse(std::string_view line, Json& j, std::string& detail) {
    for (int attempt = 0; attempt < 2; ++attempt) {
      had_sentinels = replace_nonfinite_tokens(line, rewritten, reps, attempt == 1);
      const std::string_view text = had_sentinels ? std::string_view(rewritten) : line;
      try {
        j = Json::parse(text.begin(), text.end());
        return true;
      } catch (const nlohmann::json::parse_error& e) {
        // e.what(): "[json.exception.parse_error.101] parse error at line 1, column 5: syntax error ..."
        const std::string what = e.what();
        std::string reason = what;
        const std::size_t c = what.find("column ");
        if (c != std::string::npos) {
          const std::size_t colon = what.find(": ", c);
          if (colon != std::string::npos) reason = what.substr(colon + 2);
        }
        std::size_t col = e.byte;
        if (had_sentinels) {
          col = original_column(col, reps);
          reason = without_sentinels(std::move(reason));
        }
        if (col > line.size() + 1) col = line.size() + 1;
        detail = " at column " + std::to_string(col) + ": " + reason;
        return false;
      } catch (const nlohmann::json::out_of_range& e) {
        if (e.id == 406 && attempt == 0) continue;  // number overflow: retry, reading it as +-inf
        detail = std::string(": ") + e.what();
        return false;
      } catch (const std::exception& e) {
        detail = std::string(": ") + e.what();
        return false;
      }
    }
    detail = ": internal error";  // not reached: the second attempt has no overflowing number left
    return false;
  }

  // Converts a JSON value to double when it is a number, null (NaN) or a non-finite sentinel.
  bool to_double(const Json& e, double& v) const {
    if (e.is_number()) {
      v = e.get<double>();
      return true;
    }
    if (e.is_null()) {
      v = std::numeric_limits<double>::quiet_NaN();
      return true;
    }
    if (had_sentinels && e.is_string()) {
      const std::string& s = e.get_ref<const std::string&>();
      if (s == kSentinelValue[0]) {
        v = std::numeric_limits<double>::quiet_NaN();
        return true;
      }
      if (s == kSentinelValue[1]) {
        v = std::numeric_limits<double>::infinity();
        return true;
      }
      if (s == kSentinelValue[2]) {
        v = -std::numeric_limits<double>::infinity();
        return true;
      }
    }
    return false;
  }

  // "string \"abc\"", "array", "boolean", ...
  std::string describe(const Json& e) const {
    double unused;
    if (to_double(e, unused)) return "number";
    if (!e.is_string()) return e.type_name();
    std::string s = e.get_ref<const std::string&>();
    if (s.size() > 32) {
      std::size_t n = 32;
      while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;  // cut on a UTF-8 boundary
      s = s.substr(0, n) + "...";
    }
    return "string \"" + s + "\"";
  }

  // Converts an array of numbers. On a bad element returns false with `bad` = its position.
  bool to_doubles(const Json& arr, std::vector<double>& out, std::size_t& bad) const {
    out.clear();
    out.reserve(arr.size());
    std::size_t k = 0;
    for (const Json& e : arr) {
      double v;
      if (!to_double(e, v)) {
        bad = k;
        return false;
      }
      out.push_back(v);
      ++k;
    }
    return true;
  }
};

// A value as JSON text for messages, at most ~40 bytes.
std::string short_dump(const Json& v) {
  std::string d = without_sentinels(v.dump());
  if (d.size() > 40) {
    std::size_t n = 40;
    while (n > 0 && (static_cast<unsigned char>(d[n]) & 0xC0) == 0x80) --n;  // cut on a UTF-8 boundary
    d = d.substr(0, n) + "...";
  }
  return d;
}

// Integer JSON value that fits in a long.
bool get_long(const Json& e, long& out) {
  if (e.is_number_unsigned()) {
    const auto u = e.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(LONG_MAX)) return false;
    out = static_cast<long>(u);
    return true;
  }
  if (e.is_number_integer()) {
    const auto s = e.get<std::int64_t>();
    if (s < LONG_MIN || s > LONG_MAX) return false;
    out = static_cast<long>(s);
    return true;
  }
  return false;
}

std::string where(const std::string& name, long line) { return name + ":" + std::to_string(line) + ": "; }

bool parse_header(const Json& j, LineParser& lp, const std::string& name, StateFileHeader& h, std::string& error) {
  const std::string at = where(name, h.line) + "header: ";
  if (!j.is_object()) {
    error = at + "expected a JSON object, got " + std::string(j.type_name());
    return false;
  }
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    const Json& v = it.value();
    if (key == "robot") {
      if (!v.is_string()) {
        error = at + "field 'robot' must be a string, got " + short_dump(v);
        return false;
      }
      h.robot = v.get<std::string>();
    } else if (key == "nv" || key == "nq") {
      long n = -1;
      if (!get_long(v, n) || n < 0) {
        error = at + "field '" + key + "' must be a non-negative integer, got " + short_dump(v);
        return false;
      }
      (key == "nv" ? h.nv : h.nq) = n;
    } else if (key == "joint_names") {
      if (!v.is_array()) {
        error = at + "field 'joint_names' must be an array of strings, got " + std::string(v.type_name());
        return false;
      }
      h.joint_names.clear();
      std::size_t k = 0;
      for (const Json& e : v) {
        if (!e.is_string()) {
          error = at + "field 'joint_names' element " + std::to_string(k) + " is not a string (got " +
                  lp.describe(e) + ")";
          return false;
        }
        h.joint_names.push_back(e.get<std::string>());
        ++k;
      }
    } else if (v.is_array()) {
      std::vector<double> vals;
      std::size_t bad = 0;
      if (lp.to_doubles(v, vals, bad)) h.fields[key] = std::move(vals);  // else: not a numeric array, skip
    }
  }
  return true;
}

bool parse_state(const Json& j, LineParser& lp, const std::string& name, StateRecord& r, std::string& error) {
  const std::string at_line = where(name, r.line);
  if (!j.is_object()) {
    error = at_line + "expected a JSON object, got " + std::string(j.type_name());
    return false;
  }
  if (auto it = j.find("index"); it != j.end()) {
    if (!get_long(*it, r.index)) {
      error = at_line + "state at position " + std::to_string(r.index) + ": field 'index' must be an integer, got " +
              short_dump(*it);
      return false;
    }
  }
  const std::string at = at_line + "state " + std::to_string(r.index) + ": ";
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    const Json& v = it.value();
    if (key == "index") continue;
    if (key == "kind") {
      if (!v.is_string()) {
        error = at + "field 'kind' must be a string, got " + short_dump(v);
        return false;
      }
      r.kind = v.get<std::string>();
      continue;
    }
    if (!v.is_array()) continue;  // scalars, strings, objects: not state fields
    std::vector<double> vals;
    std::size_t bad = 0;
    if (!lp.to_doubles(v, vals, bad)) {
      error = at + "field '" + key + "' element " + std::to_string(bad) + " is not a number (got " +
              lp.describe(v[bad]) + ")";
      return false;
    }
    r.fields[key] = std::move(vals);
  }
  return true;
}

bool is_blank(std::string_view s) {
  for (char c : s)
    if (c != ' ' && c != '\t' && c != '\r' && c != '\n' && c != '\f' && c != '\v') return false;
  return true;
}

std::string state_prefix(const StateRecord& s) { return "state " + std::to_string(s.index) + ": "; }

}  // namespace

// -----------------------------------------------------------------------------------------------------
// StateRecord

const std::vector<double>* StateRecord::find(const std::string& f) const {
  const auto it = fields.find(f);
  return it == fields.end() ? nullptr : &it->second;
}

const std::vector<double>& StateRecord::at(const std::string& f) const {
  const auto it = fields.find(f);
  if (it == fields.end())
    throw std::out_of_range("state " + std::to_string(index) + " (line " + std::to_string(line) +
                            ") has no field '" + f + "'");
  return it->second;
}

// -----------------------------------------------------------------------------------------------------
// Reading

bool parse_state_file(std::istream& in, const std::string& name, StateFile& out, std::string& error) {
  out = StateFile{};
  error.clear();
  try {
    LineParser lp;
    Json j;
    std::string line;
    std::string detail;
    long lineno = 0;
    bool have_header = false;
    long position = 0;  // 0-based position among state lines
    while (std::getline(in, line)) {
      ++lineno;
      std::string_view text = line;
      if (lineno == 1 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
      if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
      if (is_blank(text)) continue;
      if (!lp.parse(text, j, detail)) {
        error = where(name, lineno) + "malformed JSON" + detail;
        return false;
      }
      if (!have_header) {
        out.header.line = lineno;
        out.header.json = std::string(text);
        if (!parse_header(j, lp, name, out.header, error)) return false;
        have_header = true;
        continue;
      }
      StateRecord r;
      r.line = lineno;
      r.index = position;
      if (!parse_state(j, lp, name, r, error)) return false;
      out.states.push_back(std::move(r));
      ++position;
    }
    if (in.bad()) {
      error = name + ": read error after line " + std::to_string(lineno);
      return false;
    }
    if (!have_header) {
      error = name + ": empty file (no header line)";
      return false;
    }
    return true;
  } catch (const std::exception& e) {  // std::bad_alloc and the like: never let it escape
    error = name + ": " + e.what();
    return false;
  }
}

bool read_state_file(const std::string& path, StateFile& out, std::string& error) {
  errno = 0;
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    out = StateFile{};
    error = "cannot open '" + path + "'" + (errno != 0 ? std::string(": ") + std::strerror(errno) : std::string());
    return false;
  }
  return parse_state_file(f, path, out, error);
}

// -----------------------------------------------------------------------------------------------------
// Checks

std::string check_field(const StateRecord& s, const std::string& f, long expected_size) {
  const std::vector<double>* v = s.find(f);
  if (v == nullptr) return state_prefix(s) + "missing field '" + f + "'";
  if (expected_size >= 0 && v->size() != static_cast<std::size_t>(expected_size)) {
    return state_prefix(s) + "field '" + f + "' has " + std::to_string(v->size()) +
           (v->size() == 1 ? " value" : " values") + ", expected " + std::to_string(expected_size);
  }
  for (std::size_t i = 0; i < v->size(); ++i) {
    const double x = (*v)[i];
    if (!std::isfinite(x)) {
      const char* what = std::isnan(x) ? "nan" : (x > 0 ? "inf" : "-inf");
      return state_prefix(s) + "field '" + f + "' element " + std::to_string(i) + " is not finite (" + what + ")";
    }
  }
  return {};
}

std::string check_dynamics_input(const StateRecord& s, long nv) {
  if (nv < 0) return state_prefix(s) + "nv is unknown (" + std::to_string(nv) + ")";
  for (const char* f : {"q", "qd"}) {
    std::string m = check_field(s, f, nv);
    if (!m.empty()) return m;
  }
  if (s.has("tau")) return check_field(s, "tau", nv);
  if (s.has("qdd")) return check_field(s, "qdd", nv);
  return state_prefix(s) + "needs 'tau' or 'qdd'";
}

// -----------------------------------------------------------------------------------------------------
// Writing

ResultWriter::ResultWriter(std::ostream& out) : out_(out) { buf_.reserve(1 << 16); }

bool ResultWriter::ok() const { return !out_.fail(); }

void ResultWriter::flush_line() { out_.write(buf_.data(), static_cast<std::streamsize>(buf_.size())); }

void ResultWriter::write_header(std::string_view header_json) {
  buf_.assign(header_json);
  for (char& c : buf_)
    if (c == '\n' || c == '\r') c = ' ';
  buf_ += '\n';
  flush_line();
}

void ResultWriter::begin_object(long index) {
  buf_.clear();
  buf_ += "{\"index\":";
  char b[24];
  const auto r = std::to_chars(b, b + sizeof b, index);
  buf_.append(b, r.ptr);
}

void ResultWriter::append_number(double v) {
  if (!std::isfinite(v)) {  // caller bug: keep the output valid JSON, count it
    buf_ += "null";
    ++nonfinite_;
    return;
  }
  if (v == 0.0) {
    buf_ += std::signbit(v) ? "-0.0" : "0";  // "-0" would read back as the integer 0
    return;
  }
  char b[32];
  const auto r = std::to_chars(b, b + sizeof b, v, std::chars_format::general, 17);
  buf_.append(b, r.ptr);
}

void ResultWriter::append_string(std::string_view s) {
  static constexpr char kHex[] = "0123456789abcdef";
  buf_ += '"';
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const std::size_t n = s.size();
  std::size_t i = 0;
  while (i < n) {
    const unsigned char c = p[i];
    if (c < 0x80) {
      switch (c) {
        case '"': buf_ += "\\\""; break;
        case '\\': buf_ += "\\\\"; break;
        case '\n': buf_ += "\\n"; break;
        case '\r': buf_ += "\\r"; break;
        case '\t': buf_ += "\\t"; break;
        case '\b': buf_ += "\\b"; break;
        case '\f': buf_ += "\\f"; break;
        default:
          if (c < 0x20) {
            buf_ += "\\u00";
            buf_ += kHex[c >> 4];
            buf_ += kHex[c & 15];
          } else {
            buf_ += static_cast<char>(c);
          }
      }
      ++i;
      continue;
    }
    // Multi-byte UTF-8: copy a well-formed sequence, else write U+FFFD for the first byte and resync.
    std::size_t len = 0;
    unsigned char lo = 0x80, hi = 0xBF;  // allowed range of the second byte
    if (c >= 0xC2 && c <= 0xDF) {
      len = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
      len = 3;
      if (c == 0xE0) lo = 0xA0;
      if (c == 0xED) hi = 0x9F;  // no UTF-16 surrogates
    } else if (c >= 0xF0 && c <= 0xF4) {
      len = 4;
      if (c == 0xF0) lo = 0x90;
      if (c == 0xF4) hi = 0x8F;
    }
    bool good = len != 0 && i + len <= n && p[i + 1] >= lo && p[i + 1] <= hi;
    for (std::size_t k = 2; good && k < len; ++k) good = (p[i + k] & 0xC0) == 0x80;
    if (good) {
      buf_.append(s.substr(i, len));
      i += len;
    } else {
      buf_ += "\\ufffd";
      ++i;
    }
  }
  buf_ += '"';
}

void ResultWriter::append_array(std::string_view name, const double* data, std::size_t n) {
  buf_ += ',';
  append_string(name);
  buf_ += ":[";
  for (std::size_t i = 0; i < n; ++i) {
    if (i != 0) buf_ += ',';
    append_number(data != nullptr ? data[i] : std::numeric_limits<double>::quiet_NaN());
  }
  buf_ += ']';
}

void ResultWriter::write_state(long index, std::string_view kind, std::span<const OutputArray> arrays) {
  begin_object(index);
  if (!kind.empty()) {
    buf_ += ",\"kind\":";
    append_string(kind);
  }
  for (const OutputArray& a : arrays) append_array(a.name, a.data, a.size);
  buf_ += "}\n";
  flush_line();
}

void ResultWriter::write_state(long index, std::string_view kind,
                               const std::vector<std::pair<std::string, const double*>>& arrays,
                               const std::vector<std::size_t>& sizes) {
  if (arrays.size() != sizes.size()) {
    write_error(index, "internal: write_state: " + std::to_string(arrays.size()) + " arrays but " +
                           std::to_string(sizes.size()) + " sizes");
    return;
  }
  begin_object(index);
  if (!kind.empty()) {
    buf_ += ",\"kind\":";
    append_string(kind);
  }
  for (std::size_t i = 0; i < arrays.size(); ++i) append_array(arrays[i].first, arrays[i].second, sizes[i]);
  buf_ += "}\n";
  flush_line();
}

void ResultWriter::write_error(long index, std::string_view message) {
  begin_object(index);
  buf_ += ",\"error\":";
  append_string(message);
  buf_ += "}\n";
  flush_line();
}

}  // namespace rbdgrad::io
