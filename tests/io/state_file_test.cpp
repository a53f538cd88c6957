// Tests for io/src/state_file.cpp.
#include "rbdgrad/io/state_file.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace rbdgrad::io {
namespace {

constexpr const char* kHeader =
    R"({"robot":"two.urdf","nq":2,"nv":2,"joint_names":["j1","j2"],"joint_types":["RZ","RZ"],)"
    R"("gravity":[0,0,-9.8100000000000005],"n_states":2})";

bool parse(const std::string& text, StateFile& f, std::string& err, const std::string& name = "s.jsonl") {
  std::istringstream in(text);
  return parse_state_file(in, name, f, err);
}

std::uint64_t bits(double x) {
  std::uint64_t u;
  std::memcpy(&u, &x, sizeof u);
  return u;
}

TEST(StateFile, HeaderParsed) {
  StateFile f;
  std::string err;
  ASSERT_TRUE(parse(std::string(kHeader) + "\n", f, err)) << err;
  EXPECT_EQ(f.header.robot, "two.urdf");
  EXPECT_EQ(f.header.nv, 2);
  EXPECT_EQ(f.header.nq, 2);
  EXPECT_EQ(f.header.joint_names, (std::vector<std::string>{"j1", "j2"}));
  EXPECT_EQ(f.header.json, kHeader);
  EXPECT_EQ(f.header.line, 1);
  ASSERT_EQ(f.header.fields.count("gravity"), 1u);
  EXPECT_EQ(f.header.fields.at("gravity"), (std::vector<double>{0, 0, -9.81}));
  EXPECT_EQ(f.header.fields.count("joint_types"), 0u);  // not numeric
  EXPECT_TRUE(f.states.empty());
}

TEST(StateFile, HeaderWithoutNvAndBadNv) {
  StateFile f;
  std::string err;
  ASSERT_TRUE(parse("{\"robot\":\"x\"}\n", f, err)) << err;
  EXPECT_EQ(f.header.nv, -1);
  EXPECT_FALSE(parse("{\"nv\":\"7\"}\n", f, err));
  EXPECT_EQ(err, "s.jsonl:1: header: field 'nv' must be a non-negative integer, got \"7\"");
  EXPECT_FALSE(parse("{\"nq\":NaN}\n", f, err));
  EXPECT_EQ(err, "s.jsonl:1: header: field 'nq' must be a non-negative integer, got NaN");
  EXPECT_FALSE(parse("{\"joint_names\":[\"a\",3]}\n", f, err));
  EXPECT_NE(err.find("'joint_names' element 1 is not a string"), std::string::npos) << err;
}

TEST(StateFile, FieldsReadExactly) {
  StateFile f;
  std::string err;
  const std::string text = std::string(kHeader) + "\n" +
                           R"({"index":0,"kind":"random","q":[0.10000000000000001,-9.8100000000000005],)"
                           R"("qd":[1e-300,320],"tau":[-0.0,4.9406564584124654e-324],"M":[1,2,3,4],)"
                           R"("note":"ignored","scalar":5})" "\n";
  ASSERT_TRUE(parse(text, f, err)) << err;
  ASSERT_EQ(f.states.size(), 1u);
  const StateRecord& s = f.states[0];
  EXPECT_EQ(s.kind, "random");
  EXPECT_EQ(s.line, 2);
  EXPECT_EQ(bits(s.at("q")[0]), bits(0.1));
  EXPECT_EQ(bits(s.at("q")[1]), bits(-9.81));
  EXPECT_EQ(bits(s.at("qd")[0]), bits(1e-300));
  EXPECT_EQ(s.at("qd")[1], 320.0);
  EXPECT_EQ(bits(s.at("tau")[0]), bits(-0.0));
  EXPECT_EQ(s.at("tau")[1], std::numeric_limits<double>::denorm_min());
  EXPECT_EQ(s.at("M"), (std::vector<double>{1, 2, 3, 4}));
  EXPECT_FALSE(s.has("note"));
  EXPECT_FALSE(s.has("scalar"));
  EXPECT_EQ(s.fields.size(), 4u);
}

TEST(StateFile, WriteThenReadIsBitExact) {
  std::vector<double> v = {0.1,
                           1.0 / 3.0,
                           -9.81,
                           -0.0,
                           0.0,
                           320.0,
                           1e16,
                           1e17 + 16,
                           123456789012345678.0,
                           std::numeric_limits<double>::max(),
                           -std::numeric_limits<double>::max(),
                           std::numeric_limits<double>::min(),
                           std::numeric_limits<double>::denorm_min(),
                           -std::numeric_limits<double>::denorm_min(),
                           std::numeric_limits<double>::epsilon(),
                           5e-324 * 12345};
  std::mt19937_64 rng(12345);
  while (v.size() < 4000) {
    const std::uint64_t u = rng();
    double x;
    std::memcpy(&x, &u, sizeof x);
    if (std::isfinite(x)) v.push_back(x);
  }
  std::uniform_real_distribution<double> uni(-10.0, 10.0);
  for (int i = 0; i < 4000; ++i) v.push_back(uni(rng));

  std::ostringstream os;
  ResultWriter w(os);
  w.write_header(kHeader);
  const OutputArray arrays[] = {{"qdd", v.data(), v.size()}, {"M", v.data(), 4}};
  w.write_state(7, "random", arrays);
  EXPECT_EQ(w.nonfinite_count(), 0u);
  EXPECT_TRUE(w.ok());

  StateFile f;
  std::string err;
  ASSERT_TRUE(parse(os.str(), f, err)) << err;
  ASSERT_EQ(f.states.size(), 1u);
  EXPECT_EQ(f.states[0].index, 7);
  EXPECT_EQ(f.states[0].kind, "random");
  const std::vector<double>& back = f.states[0].at("qdd");
  ASSERT_EQ(back.size(), v.size());
  for (std::size_t i = 0; i < v.size(); ++i) ASSERT_EQ(bits(back[i]), bits(v[i])) << "element " << i << " " << v[i];
  ASSERT_EQ(f.states[0].at("M").size(), 4u);
}

TEST(StateFile, WriterFormat) {
  std::ostringstream os;
  ResultWriter w(os);
  w.write_header("{\"robot\":\"a\",\n\"nv\":1}\n");
  const double a[] = {1.0, -0.0, 0.5, 1e100};
  const double b[] = {2.0};
  w.write_state(3, "", std::vector<OutputArray>{{"z", a, 4}, {"a", b, 1}});
  w.write_state(4, "grid", std::vector<std::pair<std::string, const double*>>{{"x", b}}, std::vector<std::size_t>{1});
  EXPECT_EQ(os.str(),
            "{\"robot\":\"a\", \"nv\":1} \n"
            "{\"index\":3,\"z\":[1,-0.0,0.5,1e+100],\"a\":[2]}\n"
            "{\"index\":4,\"kind\":\"grid\",\"x\":[2]}\n");
}

TEST(StateFile, WriterNeverWritesNanTokens) {
  std::ostringstream os;
  ResultWriter w(os);
  const double a[] = {std::nan(""), std::numeric_limits<double>::infinity(),
                      -std::numeric_limits<double>::infinity(), 1.5};
  w.write_state(0, "k", std::vector<OutputArray>{{"v", a, 4}});
  EXPECT_EQ(os.str(), "{\"index\":0,\"kind\":\"k\",\"v\":[null,null,null,1.5]}\n");
  EXPECT_EQ(w.nonfinite_count(), 3u);
}

TEST(StateFile, WriterSizeMismatchWritesErrorLine) {
  std::ostringstream os;
  ResultWriter w(os);
  const double b[] = {2.0};
  w.write_state(9, "", std::vector<std::pair<std::string, const double*>>{{"x", b}, {"y", b}},
                std::vector<std::size_t>{1});
  const auto j = nlohmann::json::parse(os.str());
  EXPECT_EQ(j.at("index"), 9);
  EXPECT_EQ(j.at("error"), "internal: write_state: 2 arrays but 1 sizes");
}

TEST(StateFile, IndexDefaultsToPosition) {
  StateFile f;
  std::string err;
  const std::string text = std::string(kHeader) + "\n\n" +   // blank line 2
                           "{\"q\":[1,2]}\n" +                 // line 3, position 0
                           "   \n" +                           // blank line 4
                           "{\"index\":42,\"q\":[1,2]}\n" +    // line 5, explicit index
                           "{\"q\":[3,4]}\r\n";                // line 6, position 2 (CRLF)
  ASSERT_TRUE(parse(text, f, err)) << err;
  ASSERT_EQ(f.states.size(), 3u);
  EXPECT_EQ(f.states[0].index, 0);
  EXPECT_EQ(f.states[0].line, 3);
  EXPECT_EQ(f.states[0].kind, "");
  EXPECT_EQ(f.states[1].index, 42);
  EXPECT_EQ(f.states[1].line, 5);
  EXPECT_EQ(f.states[2].index, 2);
  EXPECT_EQ(f.states[2].line, 6);
  EXPECT_EQ(f.states[2].at("q"), (std::vector<double>{3, 4}));
}

TEST(StateFile, BadIndexAndKindAreErrors) {
  StateFile f;
  std::string err;
  EXPECT_FALSE(parse(std::string(kHeader) + "\n{\"index\":1.5,\"q\":[1]}\n", f, err));
  EXPECT_EQ(err, "s.jsonl:2: state at position 0: field 'index' must be an integer, got 1.5");
  EXPECT_FALSE(parse(std::string(kHeader) + "\n{\"index\":4,\"kind\":7}\n", f, err));
  EXPECT_EQ(err, "s.jsonl:2: state 4: field 'kind' must be a string, got 7");
}

TEST(StateFile, NonFiniteElementsAreKeptAndReported) {
  StateFile f;
  std::string err;
  const std::string text = std::string(kHeader) + "\n" +
                           R"({"index":3,"q":[0,0],"qd":[1,NaN],"tau":[1,1],"x":[null,Infinity,-Infinity,-NaN,nan,inf,-inf]})" "\n" +
                           R"({"index":4,"q":[0,0],"qd":[0,0],"tau":[1,Infinity]})" "\n" +
                           R"({"index":5,"q":[0,null],"qd":[0,0],"qdd":[0,0]})" "\n" +
                           R"({"index":6,"q":[0,0],"qd":[0,0],"qdd":[-Infinity,0]})" "\n" +
                           R"({"index":7,"q":[0,0],"qd":[0,0],"tau":[0,0]})" "\n";
  ASSERT_TRUE(parse(text, f, err)) << err;
  ASSERT_EQ(f.states.size(), 5u);

  const std::vector<double>& x = f.states[0].at("x");
  ASSERT_EQ(x.size(), 7u);
  EXPECT_TRUE(std::isnan(x[0]));
  EXPECT_EQ(x[1], std::numeric_limits<double>::infinity());
  EXPECT_EQ(x[2], -std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(x[3]));
  EXPECT_TRUE(std::isnan(x[4]));
  EXPECT_EQ(x[5], std::numeric_limits<double>::infinity());
  EXPECT_EQ(x[6], -std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(f.states[0].at("qd")[1]));

  EXPECT_EQ(check_dynamics_input(f.states[0], 2), "state 3: field 'qd' element 1 is not finite (nan)");
  EXPECT_EQ(check_dynamics_input(f.states[1], 2), "state 4: field 'tau' element 1 is not finite (inf)");
  EXPECT_EQ(check_dynamics_input(f.states[2], 2), "state 5: field 'q' element 1 is not finite (nan)");
  EXPECT_EQ(check_dynamics_input(f.states[3], 2), "state 6: field 'qdd' element 0 is not finite (-inf)");
  EXPECT_EQ(check_dynamics_input(f.states[4], 2), "");
  EXPECT_EQ(check_field(f.states[0], "x", 7), "state 3: field 'x' element 0 is not finite (nan)");
}

TEST(StateFile, OverflowingNumbersReadAsInfinity) {
  // Python's json reads 1e999 as inf; nlohmann rejects it, so the reader retries and stores +-Inf.
  StateFile f;
  std::string err;
  EXPECT_FALSE(parse(std::string(kHeader) + "\n" +
                         R"({"index":1,"q":[1e999, -2E+400, 1e-999, 0.5],"s":"1e999","r":["1e999"]})" "\n",
                     f, err));
  EXPECT_EQ(err, "s.jsonl:2: state 1: field 'r' element 0 is not a number (got string \"1e999\")");
  ASSERT_TRUE(parse(std::string(kHeader) + "\n" + R"({"index":1,"q":[1e999, -2E+400, 1e-999, 0.5],"s":"1e999"})" "\n",
                    f, err))
      << err;
  const std::vector<double>& q = f.states.at(0).at("q");
  ASSERT_EQ(q.size(), 4u);
  EXPECT_EQ(q[0], std::numeric_limits<double>::infinity());
  EXPECT_EQ(q[1], -std::numeric_limits<double>::infinity());
  EXPECT_EQ(q[2], 0.0);
  EXPECT_EQ(q[3], 0.5);
  EXPECT_EQ(check_field(f.states[0], "q", 4), "state 1: field 'q' element 0 is not finite (inf)");
}

TEST(StateFile, WrongLengthNamed) {
  StateFile f;
  std::string err;
  ASSERT_TRUE(parse(std::string(kHeader) + "\n" +
                        R"({"index":3,"q":[1,2,3,4,5,6],"qd":[1,2,3,4,5,6,7],"tau":[1,2,3,4,5,6,7]})" "\n" +
                        R"({"index":4,"q":[1,2,3,4,5,6,7],"qd":[1],"tau":[1,2,3,4,5,6,7]})" "\n",
                    f, err))
      << err;
  ASSERT_EQ(f.states.size(), 2u);
  EXPECT_EQ(check_dynamics_input(f.states[0], 7), "state 3: field 'q' has 6 values, expected 7");
  EXPECT_EQ(check_dynamics_input(f.states[1], 7), "state 4: field 'qd' has 1 value, expected 7");
  EXPECT_EQ(check_dynamics_input(f.states[0], 6), "state 3: field 'qd' has 7 values, expected 6");
  EXPECT_EQ(check_field(f.states[0], "M", 49), "state 3: missing field 'M'");
  EXPECT_EQ(check_dynamics_input(f.states[0], -1), "state 3: nv is unknown (-1)");
}

TEST(StateFile, MissingTauAndQddNamed) {
  StateFile f;
  std::string err;
  ASSERT_TRUE(parse(std::string(kHeader) + "\n" +
                        R"({"index":5,"q":[0,0],"qd":[0,0]})" "\n" +
                        R"({"index":6,"q":[0,0],"qd":[0,0],"qdd":[1,2]})" "\n" +
                        R"({"index":7,"q":[0,0],"qd":[0,0],"tau":[1,2],"qdd":[NaN,1,2]})" "\n" +
                        R"({"index":8,"qd":[0,0],"tau":[1,2]})" "\n",
                    f, err))
      << err;
  ASSERT_EQ(f.states.size(), 4u);
  EXPECT_EQ(check_dynamics_input(f.states[0], 2), "state 5: needs 'tau' or 'qdd'");
  EXPECT_EQ(check_dynamics_input(f.states[1], 2), "");
  EXPECT_EQ(check_dynamics_input(f.states[2], 2), "");  // tau is the input; qdd is not checked
  EXPECT_EQ(check_dynamics_input(f.states[3], 2), "state 8: missing field 'q'");
}

TEST(StateFile, MalformedLineNamesLine) {
  StateFile f;
  std::string err;
  EXPECT_FALSE(parse(std::string(kHeader) + "\n{\"q\":[1,2]}\n\n{\"q\":[1,2}\n{\"q\":[3]}\n", f, err, "states.jsonl"));
  EXPECT_EQ(err.rfind("states.jsonl:4: malformed JSON at column 10: ", 0), 0u) << err;
  EXPECT_EQ(f.states.size(), 1u);  // the states before the bad line are kept

  EXPECT_FALSE(parse("{\"robot\":\"a\"\n", f, err));
  EXPECT_EQ(err.rfind("s.jsonl:1: malformed JSON", 0), 0u) << err;

  EXPECT_FALSE(parse(std::string(kHeader) + "\n[1,2,3]\n", f, err));
  EXPECT_EQ(err, "s.jsonl:2: expected a JSON object, got array");

  EXPECT_FALSE(parse(std::string(kHeader) + "\n{\"index\":3,\"q\":[1,2],\"qd\":[0,1,\"x\"]}\n", f, err));
  EXPECT_EQ(err, "s.jsonl:2: state 3: field 'qd' element 2 is not a number (got string \"x\")");

  EXPECT_FALSE(parse(std::string(kHeader) + "\n{\"index\":3,\"M\":[[1,2],[3,4]]}\n", f, err));
  EXPECT_EQ(err, "s.jsonl:2: state 3: field 'M' element 0 is not a number (got array)");

  EXPECT_FALSE(parse("", f, err));
  EXPECT_EQ(err, "s.jsonl: empty file (no header line)");
}

TEST(StateFile, MalformedColumnIsInOriginalLine) {
  // "NaN" and "0.5" have the same length, so the column must be the same although NaN is rewritten.
  StateFile f;
  std::string err_nan, err_num;
  EXPECT_FALSE(parse(std::string(kHeader) + "\n{\"q\":[NaN,Infinity,tru]}\n", f, err_nan));
  EXPECT_FALSE(parse(std::string(kHeader) + "\n{\"q\":[0.5,12345678,tru]}\n", f, err_num));
  const auto column = [](const std::string& e) { return e.substr(0, e.find(':', e.find("column"))); };
  EXPECT_EQ(column(err_nan), column(err_num));
  EXPECT_NE(err_nan.find("column"), std::string::npos) << err_nan;
}

TEST(StateFile, NanInsideStringLiteralsIsNotMangled) {
  const std::string header =
      R"({"robot":"NaN Infinity -Infinity \"NaN\" \\NaN","nv":1,"joint_names":["NaN","-Infinity"]})";
  const std::string state = R"({"index":0,"kind":"NaN, Infinity","q":[NaN],"s":"x\"NaN\"","t":[1]})";
  StateFile f;
  std::string err;
  ASSERT_TRUE(parse(header + "\n" + state + "\n", f, err)) << err;
  EXPECT_EQ(f.header.robot, "NaN Infinity -Infinity \"NaN\" \\NaN");
  EXPECT_EQ(f.header.joint_names, (std::vector<std::string>{"NaN", "-Infinity"}));
  EXPECT_EQ(f.header.json, header);
  ASSERT_EQ(f.states.size(), 1u);
  EXPECT_EQ(f.states[0].kind, "NaN, Infinity");
  EXPECT_TRUE(std::isnan(f.states[0].at("q")[0]));
  EXPECT_EQ(f.states[0].at("t"), std::vector<double>{1});

  // A string element spelled "NaN" is a string, not a number.
  EXPECT_FALSE(parse(header + "\n{\"index\":2,\"q\":[\"NaN\"]}\n", f, err));
  EXPECT_EQ(err, "s.jsonl:2: state 2: field 'q' element 0 is not a number (got string \"NaN\")");
}

TEST(StateFile, WriteErrorParsesBack) {
  const std::string message = "state 3: bad \"q\" \\ path\nline2\ttab \x01 caf\xC3\xA9 bad\xFF byte";
  std::ostringstream os;
  ResultWriter w(os);
  w.write_header(kHeader);
  w.write_error(3, message);
  const std::string out = os.str();
  const std::string line = out.substr(out.find('\n') + 1);
  ASSERT_EQ(line.back(), '\n');
  EXPECT_EQ(line.find('\n'), line.size() - 1);  // one line

  const auto j = nlohmann::json::parse(line);
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j.size(), 2u);
  EXPECT_EQ(j.at("index"), 3);
  EXPECT_EQ(j.at("error"), "state 3: bad \"q\" \\ path\nline2\ttab \x01 caf\xC3\xA9 bad\xEF\xBF\xBD byte");

  StateFile f;
  std::string err;
  ASSERT_TRUE(parse(out, f, err)) << err;
  ASSERT_EQ(f.states.size(), 1u);
  EXPECT_EQ(f.states[0].index, 3);
  EXPECT_TRUE(f.states[0].fields.empty());
}

TEST(StateFile, RecordAccessors) {
  StateRecord s;
  s.index = 3;
  s.line = 5;
  s.fields["q"] = {1.0};
  EXPECT_TRUE(s.has("q"));
  EXPECT_FALSE(s.has("qd"));
  EXPECT_EQ(s.find("qd"), nullptr);
  ASSERT_NE(s.find("q"), nullptr);
  EXPECT_EQ(s.at("q"), std::vector<double>{1.0});
  try {
    (void)s.at("qd");
    FAIL() << "no exception";
  } catch (const std::out_of_range& e) {
    EXPECT_NE(std::string(e.what()).find("'qd'"), std::string::npos) << e.what();
  }
}

TEST(StateFile, ByteOrderMarkAndMissingFile) {
  StateFile f;
  std::string err;
  ASSERT_TRUE(parse("\xEF\xBB\xBF{\"robot\":\"bom\",\"nv\":1}\r\n{\"q\":[1]}", f, err)) << err;
  EXPECT_EQ(f.header.robot, "bom");
  EXPECT_EQ(f.header.json, "{\"robot\":\"bom\",\"nv\":1}");
  ASSERT_EQ(f.states.size(), 1u);  // last line without '\n' still read

  EXPECT_FALSE(read_state_file("/nonexistent/dir/states.jsonl", f, err));
  EXPECT_EQ(err.rfind("cannot open '/nonexistent/dir/states.jsonl'", 0), 0u) << err;
}

}  // namespace
}  // namespace rbdgrad::io
