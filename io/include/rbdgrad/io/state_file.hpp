// State files (JSON Lines): reading reference/input states and writing results.
//
// Format: the first non-empty line is a header object, e.g.
//   {"robot":"iiwa14.urdf","nq":7,"nv":7,"joint_names":[...],"gravity":[0,0,-9.81],...}
// and every further non-empty line is one state object, e.g.
//   {"index":0,"kind":"random","q":[...],"qd":[...],"tau":[...],"qdd":[...],"M":[...nv*nv, row-major],...}
// Blank lines are skipped, a trailing '\r' (CRLF files) and a UTF-8 byte-order mark are ignored.
//
// Non-finite numbers: the reader accepts the tokens Python's json module writes (NaN, Infinity, -Infinity),
// the C printf spellings (nan, -nan, inf, -inf, infinity, -infinity) and -NaN outside of string literals,
// and null array elements; they are stored as NaN / +Inf / -Inf so that a bad state can be reported on its
// own (check_dynamics_input, check_field) while the other states are still evaluated.
// The writer never writes those tokens (see ResultWriter).
//
// Error handling: read/parse functions return false and fill `error`; they do not throw (the one exception
// is StateRecord::at, which throws std::out_of_range by design; use StateRecord::find to avoid it).
#pragma once

#include <cstddef>
#include <iosfwd>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rbdgrad::io {

// One state line.
struct StateRecord {
  long index = 0;     // the "index" field if present, else the 0-based position among state lines
  std::string kind;   // the "kind" field; empty if absent
  long line = 0;      // 1-based line number in the file (for messages)
  // Every array-valued field, converted to double (null / NaN tokens -> NaN, Infinity -> +-Inf).
  // Fields that are neither arrays nor "index"/"kind" (strings, scalars, objects) are ignored.
  std::map<std::string, std::vector<double>> fields;

  bool has(const std::string& f) const { return fields.count(f) != 0; }
  // nullptr when absent.
  const std::vector<double>* find(const std::string& f) const;
  // Throws std::out_of_range("state 3 (line 5) has no field 'qd'") when absent.
  const std::vector<double>& at(const std::string& f) const;
};

struct StateFileHeader {
  std::string robot;                      // "robot"; empty if absent
  long nq = -1;                           // "nq"; -1 if absent
  long nv = -1;                           // "nv"; -1 if absent
  std::vector<std::string> joint_names;   // "joint_names"; empty if absent
  // Every array of numbers in the header ("gravity", "lower_limit", "joint_parent_index", ...), as doubles.
  // Arrays holding anything else (e.g. "joint_types") are not listed here (they are in `json`).
  std::map<std::string, std::vector<double>> fields;
  std::string json;                       // the header line verbatim (without line terminator / BOM)
  long line = 0;                          // 1-based line number of the header
};

struct StateFile {
  StateFileHeader header;
  std::vector<StateRecord> states;   // in file order
};

// Reads a whole file. Returns false and fills `error` on an I/O failure, an empty file, malformed JSON,
// a line that is not an object, a header field of the wrong type ("nv" not a non-negative integer, ...),
// an "index" that is not an integer, a "kind" that is not a string, or an array element that is neither
// a number, null nor a non-finite token. Messages name the file, the line and, for a state, its index:
//   "states.jsonl:5: malformed JSON at column 17: syntax error while parsing value - invalid literal; ..."
//   "states.jsonl:5: state 3: field 'qd' element 2 is not a number (got string \"x\")"
// Non-finite values are NOT errors here (see the top of this file).
// On failure `out` holds the header and the states read before the failing line.
bool read_state_file(const std::string& path, StateFile& out, std::string& error);
bool parse_state_file(std::istream& in, const std::string& name_for_messages, StateFile& out,
                      std::string& error);

// Checks field `f` of `s`: present, exactly `expected_size` values (skipped if expected_size < 0),
// all finite. Returns "" when fine, else e.g.
//   "state 3: missing field 'M'"
//   "state 3: field 'M' has 48 values, expected 49"
//   "state 3: field 'M' element 2 is not finite (nan)"      (or (inf), (-inf))
std::string check_field(const StateRecord& s, const std::string& f, long expected_size);

// Checks the inputs a dynamics evaluation needs: q and qd (nv values each, finite) and the input torque
// or acceleration: "tau" when present (then "qdd" is a reference output and is not checked), else "qdd".
// Returns "" when fine, else the first problem, e.g.
//   "state 3: field 'q' has 6 values, expected 7"
//   "state 3: field 'tau' element 2 is not finite (nan)"
//   "state 3: needs 'tau' or 'qdd'"
//   "state 3: nv is unknown (-1)"          (nv < 0, e.g. the header had no "nv")
std::string check_dynamics_input(const StateRecord& s, long nv);

// One output array: name, data, number of values (data == nullptr with size > 0 is a caller bug: written as
// `size` nulls, counted in ResultWriter::nonfinite_count()).
struct OutputArray {
  std::string_view name;
  const double* data = nullptr;
  std::size_t size = 0;
};

// Writes results as JSON Lines, one object per line, fast (no JSON library on this path).
// - Numbers: 17 significant digits (printf "%.17g" style via std::to_chars), which reads back bit-for-bit
//   equal; integral values appear without a decimal point ("320"); -0.0 is written "-0.0" so its sign survives.
// - A non-finite value is a caller bug (check inputs first): it is written as null (valid JSON; the reader
//   turns it back into NaN) and counted in nonfinite_count(). NaN/Infinity tokens are never written.
// - Strings (kind, names, messages) are escaped; invalid UTF-8 bytes become U+FFFD.
// - Each line ends with '\n'; the writer never flushes (the stream's owner does).
// Output is accepted by Python's json module (json.loads per line) and by parse_state_file.
class ResultWriter {
 public:
  explicit ResultWriter(std::ostream& out);

  // Writes the header line as given (not validated); any '\r' / '\n' in it is replaced by a space so that
  // it stays one line (raw newlines can only occur between JSON tokens, where a space is equivalent).
  void write_header(std::string_view header_json);

  // {"index":3,"kind":"random","qdd":[...],"M":[...]}: "index" first, "kind" only when non-empty,
  // then the arrays in the order given.
  void write_state(long index, std::string_view kind, std::span<const OutputArray> arrays);
  // Same, with names/pointers and sizes in parallel vectors. arrays.size() must equal sizes.size(); if it
  // does not (a caller bug) an error line {"index":..,"error":"internal: write_state: ..."} is written instead.
  void write_state(long index, std::string_view kind,
                   const std::vector<std::pair<std::string, const double*>>& arrays,
                   const std::vector<std::size_t>& sizes);

  // {"index":3,"error":"..."}
  void write_error(long index, std::string_view message);

  // Number of non-finite values written as null so far.
  std::size_t nonfinite_count() const { return nonfinite_; }
  // False once the underlying stream has failed.
  bool ok() const;

 private:
  void begin_object(long index);
  void append_string(std::string_view s);
  void append_number(double v);
  void append_array(std::string_view name, const double* data, std::size_t n);
  void flush_line();

  std::ostream& out_;
  std::string buf_;
  std::size_t nonfinite_ = 0;
};

}  // namespace rbdgrad::io
