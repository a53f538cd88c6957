// Tests for core/src/urdf.cpp: structure of the loaded models and the errors for bad URDF.
#include <gtest/gtest.h>

#include "../support/test_models.hpp"
#include <cstdio>
#include <malloc.h>  // mallinfo2: the heap in use (glibc)

#include "rbdgrad/algorithm/rnea.hpp"

namespace rbdgrad {
namespace {

const char* kInertial =
    R"(<inertial><origin xyz="0.1 0 0"/><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>)";

std::string link(const std::string& name, bool inertial = true) {
  return "<link name=\"" + name + "\">" + (inertial ? kInertial : "") + "</link>";
}
std::string joint(const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child, const std::string& axis = "0 0 1") {
  return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent + "\"/><child link=\"" +
         child + "\"/><origin xyz=\"0 0 0.3\" rpy=\"0.1 0.2 0.3\"/><axis xyz=\"" + axis +
         "\"/><limit lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"1\"/></joint>";
}
std::string robot(const std::string& body) { return "<robot name=\"r\">" + body + "</robot>"; }

Status load(const std::string& xml, Model& m) { return load_urdf_string(xml, "test.urdf", m); }

TEST(Urdf, ShippedRobotsHaveTheReferenceStructure) {
  EXPECT_EQ(testing::load_embedded("iiwa14").nv, 7);
  EXPECT_EQ(testing::load_embedded("panda").nv, 9);
  EXPECT_EQ(testing::load_embedded("hyq").nv, 12);
  const Model talos = testing::load_embedded("talos_reduced");
  EXPECT_EQ(talos.nv, 32);
  EXPECT_EQ(talos.max_depth(), 10);  // torso 2 + arm 7 + gripper 1
}

TEST(Urdf, FixedJointsAreMergedIntoTheirParentBody) {
  Model merged, plain;
  const std::string base = link("base", false) + link("a") + joint("j", "revolute", "base", "a");
  ASSERT_TRUE(load(robot(base + link("b") + joint("weld", "fixed", "a", "b")), merged).is_ok());
  ASSERT_TRUE(load(robot(base), plain).is_ok());
  ASSERT_EQ(merged.nv, 1);
  EXPECT_DOUBLE_EQ(merged.mass[0], 2.0);
  EXPECT_DOUBLE_EQ(plain.mass[0], 1.0);
}

TEST(Urdf, AnyAxisGivesTheSameDynamicsAsTheEquivalentZAxis) {
  // A joint about +y equals a joint about +z whose frame is turned by Rx(-90 deg) (which maps z to y),
  // with the child's inertia and the grandchild joint expressed in the turned frame.
  const Eigen::Matrix3d R0 = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX())).toRotationMatrix();
  const Eigen::Matrix3d Rx = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  auto rpy = [](const Eigen::Matrix3d& R) {
    const Eigen::Vector3d ypr = R.eulerAngles(2, 1, 0);
    char buf[128];
    std::snprintf(buf, sizeof buf, "%.17g %.17g %.17g", ypr(2), ypr(1), ypr(0));
    return std::string(buf);
  };
  auto xyz = [](const Eigen::Vector3d& p) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "%.17g %.17g %.17g", p(0), p(1), p(2));
    return std::string(buf);
  };
  const std::string limit = R"(<limit lower="-1" upper="1" effort="10" velocity="1"/>)";
  auto model = [&](const Eigen::Matrix3d& joint_R, const std::string& axis, const Eigen::Matrix3d& child_R) {
    // child_R: orientation of the old child frame seen from the new one
    const Eigen::Vector3d com = child_R * Eigen::Vector3d(0.1, 0.05, -0.02);
    const Eigen::Vector3d next = child_R * Eigen::Vector3d(0.0, 0.2, 0.3);
    return robot(link("base", false) +
                 "<link name=\"a\"><inertial><origin xyz=\"" + xyz(com) + "\" rpy=\"" + rpy(child_R) +
                 "\"/><mass value=\"2\"/><inertia ixx=\"0.3\" ixy=\"0.01\" ixz=\"0\" iyy=\"0.2\" iyz=\"0.02\" izz=\"0.1\"/></inertial></link>" +
                 link("b") +
                 "<joint name=\"j\" type=\"revolute\"><parent link=\"base\"/><child link=\"a\"/><origin xyz=\"0 0 0.3\" rpy=\"" +
                 rpy(joint_R) + "\"/><axis xyz=\"" + axis + "\"/>" + limit + "</joint>" +
                 "<joint name=\"k\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><origin xyz=\"" + xyz(next) +
                 "\" rpy=\"" + rpy(child_R) + "\"/><axis xyz=\"1 0 0\"/>" + limit + "</joint>");
  };
  Model y_axis, z_axis;
  ASSERT_TRUE(load(model(R0, "0 1 0", Eigen::Matrix3d::Identity()), y_axis).is_ok());
  ASSERT_TRUE(load(model(R0 * Rx, "0 0 1", Rx.transpose()), z_axis).is_ok());
  Workspace w1(y_axis), w2(z_axis);
  Eigen::VectorXd q(2), qd(2), qdd(2);
  q << 0.4, -0.3;
  qd << 0.7, 1.1;
  qdd << -1.1, 0.5;
  ASSERT_TRUE(rnea(y_axis, w1, q, qd, qdd).is_ok());
  ASSERT_TRUE(rnea(z_axis, w2, q, qd, qdd).is_ok());
  EXPECT_NEAR(w1.tau(0), w2.tau(0), 1e-12 * (1 + std::abs(w1.tau(0))));
  EXPECT_NEAR(w1.tau(1), w2.tau(1), 1e-12 * (1 + std::abs(w1.tau(1))));
  EXPECT_GT(std::abs(w1.tau(0)), 1e-3);  // not trivially zero
}

struct BadCase {
  const char* name;
  std::string xml;
  const char* expected;  // substring of the message
};

class UrdfErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(UrdfErrors, NameTheFileAndTheCulprit) {
  Model m;
  const Status s = load(GetParam().xml, m);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("test.urdf"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find(GetParam().expected), std::string::npos) << s.message();
}

std::vector<BadCase> bad_cases() {
  const std::string base = link("base", false);
  return {
      {"malformed", "<robot name=\"r\"><link name=\"a\"></robot>", "malformed URDF"},
      {"floating", robot(base + link("a") + joint("free", "floating", "base", "a")), "'free': floating joints are not supported yet"},
      {"planar", robot(base + link("a") + joint("slide", "planar", "base", "a")), "'slide': planar joints are not supported yet"},
      {"loop", robot(base + link("a") + link("b") + joint("j1", "revolute", "base", "a") +
                     joint("j2", "revolute", "a", "b") + joint("j3", "revolute", "b", "a")),
       "closed kinematic loop"},
      {"missing_inertial", robot(base + link("a", false) + joint("j", "revolute", "base", "a")),
       "link 'a' (moved by joint 'j') has no <inertial>"},
      {"negative_inertia",
       robot(base +
             R"(<link name="a"><inertial><mass value="1"/><inertia ixx="-1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>)" +
             joint("j", "revolute", "base", "a")),
       "link 'a': inertia tensor is not positive semi-definite"},
      {"singular_axis",
       robot(base +
             R"(<link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="0"/></inertial></link>)" +
             R"(<joint name="spin" type="continuous"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/></joint>)"),
       "joint 'spin' moves no rotational inertia about its axis"},
      {"no_moving_joint", robot(base + link("a") + joint("w", "fixed", "base", "a")), "no moving joint"},
  };
}

INSTANTIATE_TEST_SUITE_P(Bad, UrdfErrors, ::testing::ValuesIn(bad_cases()),
                         [](const ::testing::TestParamInfo<BadCase>& p) { return std::string(p.param.name); });

// urdfdom's links own their child links (shared_ptr): a closed loop that parseURDF returns is a
// cycle of owners, which load_urdf_string must break before it drops the parsed model (found by
// fuzz/urdf_fuzzer: such a load leaked what the parser built)
TEST(Urdf, RefusedLoopFreesWhatTheParserBuilt) {
  const std::string loop = robot(link("base", false) + link("a") + link("b") + joint("j1", "revolute", "base", "a") +
                                 joint("j2", "revolute", "a", "b") + joint("j3", "revolute", "b", "a"));
  Model m;
  ASSERT_FALSE(load(loop, m).is_ok());  // once first: one-time allocations
  const auto in_use = [] { return static_cast<long long>(mallinfo2().uordblks); };
  const long long before = in_use();
  constexpr int kLoads = 100;
  for (int i = 0; i < kLoads; ++i) (void)load(loop, m);
  EXPECT_LT(in_use() - before, kLoads * 64) << "bytes still allocated after " << kLoads << " refused loads";
}

TEST(Urdf, MissingFileIsNotFound) {
  Model m;
  const Status s = load_urdf_file("/nonexistent/robot.urdf", m);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_NE(s.message().find("/nonexistent/robot.urdf"), std::string::npos);
}

}  // namespace
}  // namespace rbdgrad
