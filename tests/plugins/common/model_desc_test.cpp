// Tests for plugins/common/model_desc.cpp: the round trip Model -> rbdgrad_model_desc -> Model and
// the validation of descriptions that come through the ABI.
#include "common/model_desc.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "../../support/test_models.hpp"

namespace rbdgrad::plugin {
namespace {

using ::testing::HasSubstr;

void expect_same_model(const Model& a, const Model& b) {
  ASSERT_EQ(a.nv, b.nv);
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.parent, b.parent);
  EXPECT_EQ(a.subtree_end, b.subtree_end);
  EXPECT_EQ(a.depth, b.depth);
  EXPECT_EQ(a.type, b.type);
  EXPECT_EQ(a.mass, b.mass);  // exact: doubles are copied, never recomputed
  EXPECT_EQ(a.gravity, b.gravity);
  for (int i = 0; i < a.nv; ++i) {
    EXPECT_EQ(a.joint_rotation[i], b.joint_rotation[i]) << i;
    EXPECT_EQ(a.joint_translation[i], b.joint_translation[i]) << i;
    EXPECT_EQ(a.com[i], b.com[i]) << i;
    EXPECT_EQ(a.inertia_com[i], b.inertia_com[i]) << i;
    EXPECT_EQ(a.link_rotation[i], b.link_rotation[i]) << i;
  }
}

std::vector<Model> models() {
  std::vector<Model> out;
  for (const char* robot : {"iiwa14", "panda", "talos_reduced", "hyq"}) out.push_back(testing::load_embedded(robot));
  out.push_back(testing::random_model(5, 15, testing::TreeShape::kBranching));
  out.push_back(testing::random_model(6, 9, testing::TreeShape::kChain));
  return out;
}

TEST(ModelDesc, RoundTripIsExact) {
  for (const Model& m : models()) {
    const ModelDesc desc(m);
    Model back;
    ASSERT_TRUE(model_from_desc(desc.desc(), back).is_ok()) << m.name;
    expect_same_model(m, back);
  }
}

TEST(ModelDesc, MatricesAreRowMajor) {
  const Model m = testing::random_model(7, 3, testing::TreeShape::kChain);
  const ModelDesc desc(m);
  for (int i = 0; i < m.nv; ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(desc.desc().joint_rotation[9 * i + 3 * r + c], m.joint_rotation[i](r, c));
        EXPECT_EQ(desc.desc().inertia_com[9 * i + 3 * r + c], m.inertia_com[i](r, c));
      }
  // a random rotation is not symmetric: a column-major copy would not pass the loop above
  EXPECT_NE(m.joint_rotation[0], m.joint_rotation[0].transpose());
  EXPECT_EQ(desc.desc().struct_size, sizeof(rbdgrad_model_desc));
  EXPECT_EQ(desc.desc().nv, 3u);
  EXPECT_STREQ(desc.desc().name, m.name.c_str());
}

TEST(ModelDesc, CopiesAndMovesPointAtTheirOwnArrays) {
  const Model m = testing::load_embedded("panda");
  ModelDesc original(m);
  ModelDesc copy(original);
  EXPECT_NE(copy.desc().mass, original.desc().mass);
  EXPECT_NE(copy.desc().name, original.desc().name);
  ModelDesc moved(std::move(copy));
  ModelDesc assigned(testing::load_embedded("iiwa14"));
  assigned = moved;
  for (const ModelDesc* d : {&original, &moved, &assigned}) {
    Model back;
    ASSERT_TRUE(model_from_desc(d->desc(), back).is_ok());
    expect_same_model(m, back);
  }
}

// A description of `m` with one thing spoilt; the arrays live in `storage`.
struct Spoilt {
  explicit Spoilt(const Model& m) : desc(m), d(desc.desc()) {
    parent.assign(d.parent, d.parent + d.nv);
    type.assign(d.joint_type, d.joint_type + d.nv);
    mass.assign(d.mass, d.mass + d.nv);
    rotation.assign(d.joint_rotation, d.joint_rotation + 9 * d.nv);
    inertia.assign(d.inertia_com, d.inertia_com + 9 * d.nv);
    link.assign(d.link_rotation, d.link_rotation + 9 * d.nv);
    d.parent = parent.data();
    d.joint_type = type.data();
    d.mass = mass.data();
    d.joint_rotation = rotation.data();
    d.inertia_com = inertia.data();
    d.link_rotation = link.data();
  }
  ModelDesc desc;
  rbdgrad_model_desc d;
  std::vector<std::int32_t> parent;
  std::vector<std::uint8_t> type;
  std::vector<double> mass, rotation, inertia, link;
};

TEST(ModelDesc, ValidationNamesTheFieldAndTheJoint) {
  const Model m = testing::load_embedded("hyq");  // a tree: four legs off the trunk
  struct Case {
    const char* expected;
    std::function<void(Spoilt&)> spoil;
  };
  const Case cases[] = {
      {"model_desc.struct_size is 8", [](Spoilt& s) { s.d.struct_size = 8; }},
      {"model_desc.name is NULL", [](Spoilt& s) { s.d.name = nullptr; }},
      {"model_desc.nv is 0", [](Spoilt& s) { s.d.nv = 0; }},
      {"model_desc.nv is 4000000000", [](Spoilt& s) { s.d.nv = 4000000000u; }},
      {"model_desc.parent is NULL", [](Spoilt& s) { s.d.parent = nullptr; }},
      {"model_desc.joint_type is NULL", [](Spoilt& s) { s.d.joint_type = nullptr; }},
      {"model_desc.joint_rotation is NULL", [](Spoilt& s) { s.d.joint_rotation = nullptr; }},
      {"model_desc.joint_translation is NULL", [](Spoilt& s) { s.d.joint_translation = nullptr; }},
      {"model_desc.mass is NULL", [](Spoilt& s) { s.d.mass = nullptr; }},
      {"model_desc.com is NULL", [](Spoilt& s) { s.d.com = nullptr; }},
      {"model_desc.inertia_com is NULL", [](Spoilt& s) { s.d.inertia_com = nullptr; }},
      {"model_desc.link_rotation is NULL", [](Spoilt& s) { s.d.link_rotation = nullptr; }},
      {"model_desc.gravity[2] is not finite", [](Spoilt& s) { s.d.gravity[2] = INFINITY; }},
      {"model_desc.parent[4] is 4", [](Spoilt& s) { s.parent[4] = 4; }},
      {"model_desc.parent[2] is -2", [](Spoilt& s) { s.parent[2] = -2; }},
      {"model_desc.joint_type[1] is 2", [](Spoilt& s) { s.type[1] = 2; }},
      {"model_desc.mass[5] (joint 5) is not finite (nan)", [](Spoilt& s) { s.mass[5] = NAN; }},
      {"model_desc.joint_rotation[13] (joint 1) is not finite", [](Spoilt& s) { s.rotation[13] = -INFINITY; }},
      {"joint 2 'joint_2': joint placement is not a finite proper rotation",
       [](Spoilt& s) { s.rotation[9 * 2] *= 2; }},
      {"model_desc.link_rotation (joint 3) is not a proper rotation", [](Spoilt& s) { s.link[9 * 3 + 4] = 0.5; }},
      {"mass must be finite and non-negative", [](Spoilt& s) { s.mass[0] = -1; }},
      {"inertia tensor is not symmetric", [](Spoilt& s) { s.inertia[9 * 6 + 1] += 0.1; }},
  };
  for (const Case& c : cases) {
    Spoilt s(m);
    c.spoil(s);
    Model out;
    out.name = "untouched";
    const Status st = model_from_desc(s.d, out);
    EXPECT_EQ(st.code(), StatusCode::kInvalidArgument) << c.expected;
    EXPECT_THAT(st.message(), HasSubstr(c.expected));
    EXPECT_EQ(out.name, "untouched") << "filled on failure: " << c.expected;
  }
}

TEST(ModelDesc, RejectsJointsOutOfDepthFirstOrder) {
  // 0 <- 1, then 2 on the world, then 3 back on 0: 0's subtree would not be a contiguous range
  Model m = testing::random_model(8, 4, testing::TreeShape::kChain);
  Spoilt s(m);
  s.parent = {-1, 0, -1, 0};
  Model out;
  const Status st = model_from_desc(s.d, out);
  EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(st.message(), HasSubstr("model_desc.parent[3] is 0 but joint 2 is outside joint 0's subtree"));
  // while a proper depth-first tree passes: 0 <- 1 <- 2, then 3 on 0
  s.parent = {-1, 0, 1, 0};
  EXPECT_TRUE(model_from_desc(s.d, out).is_ok());
  EXPECT_EQ(out.subtree_end, (std::vector<int>{4, 3, 3, 4}));
}

TEST(ModelDesc, AcceptsALargerStructFromANewerHost) {
  const Model m = testing::load_embedded("iiwa14");
  const ModelDesc desc(m);
  // a newer host's description starts with the same fields and says it is longer
  struct Newer {
    rbdgrad_model_desc base;
    double extra;
  } newer{desc.desc(), 1.0};
  newer.base.struct_size = sizeof(Newer);
  Model out;
  EXPECT_TRUE(model_from_desc(newer.base, out).is_ok());
}

}  // namespace
}  // namespace rbdgrad::plugin
