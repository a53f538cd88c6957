// Tests for plugins/common/batch_plan.{hpp,cpp} and ModelDesc::set_plan: a scene's plan (ABI 1.3)
// carried by the model description, read and checked by a plugin, and batches checked against it.
#include "common/batch_plan.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstddef>

#include "../../support/test_models.hpp"
#include "common/model_desc.hpp"

namespace rbdgrad::plugin {
namespace {

using ::testing::HasSubstr;

constexpr std::uint32_t kGradient = RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
constexpr std::uint32_t kAll = 0xff;

TEST(BatchPlan, TravelsWithTheDescriptionThroughCopiesAndMoves) {
  ModelDesc desc(testing::load_embedded("iiwa14"));
  std::optional<BatchPlan> plan;
  ASSERT_TRUE(plan_from_desc(desc.desc(), kAll, plan).is_ok());
  EXPECT_FALSE(plan) << "a description without set_plan has no plan";

  desc.set_plan(RBDGRAD_OUTPUT_DQDD_DQ, true, {2, 5});
  const ModelDesc copy(desc);
  const ModelDesc moved(std::move(desc));
  for (const ModelDesc* d : {&copy, &moved}) {
    ASSERT_NE(d->desc().plan, nullptr);
    ASSERT_TRUE(plan_from_desc(d->desc(), kAll, plan).is_ok());
    ASSERT_TRUE(plan);
    EXPECT_EQ(plan->outputs, static_cast<std::uint32_t>(RBDGRAD_OUTPUT_DQDD_DQ));
    EXPECT_TRUE(plan->minv_supplied);
    EXPECT_EQ(plan->fext_bodies, (std::vector<std::uint32_t>{2, 5}));
  }
  EXPECT_NE(copy.desc().plan, moved.desc().plan) << "each description points at its own plan";
  EXPECT_NE(copy.desc().plan->fext_bodies, moved.desc().plan->fext_bodies);
}

TEST(BatchPlan, AnOlderHostsDescriptionHasNoPlanAndIsAccepted) {
  ModelDesc desc(testing::load_embedded("iiwa14"));
  desc.set_plan(kGradient, false, {});
  rbdgrad_model_desc older = desc.desc();
  older.struct_size = offsetof(rbdgrad_model_desc, plan);  // a 1.2 host's
  std::optional<BatchPlan> plan;
  ASSERT_TRUE(plan_from_desc(older, kAll, plan).is_ok());
  EXPECT_FALSE(plan);
  Model model;
  EXPECT_TRUE(model_from_desc(older, model).is_ok());
}

TEST(BatchPlan, BadPlansNameTheField) {
  const ModelDesc base(testing::load_embedded("iiwa14"));  // 7 bodies
  const std::uint32_t bodies_out[] = {3, 7}, bodies_unsorted[] = {4, 2};
  struct Case {
    const char* what;
    rbdgrad_plan plan;
    const char* message;
  };
  const Case cases[] = {
      {"no outputs", {sizeof(rbdgrad_plan), 0, 0, 0, nullptr}, "model_desc.plan.outputs is 0"},
      {"minv_supplied 2", {sizeof(rbdgrad_plan), kGradient, 2, 0, nullptr}, "model_desc.plan.minv_supplied is 2"},
      {"body 7 of 7", {sizeof(rbdgrad_plan), kGradient, 0, 2, bodies_out},
       "model_desc.plan.fext_bodies[1] is 7, outside"},
      {"bodies not ascending", {sizeof(rbdgrad_plan), kGradient, 0, 2, bodies_unsorted},
       "model_desc.plan.fext_bodies[1] is 2, not above"},
      {"NULL bodies", {sizeof(rbdgrad_plan), kGradient, 0, 1, nullptr}, "model_desc.plan.fext_bodies is NULL"},
      {"more bodies than the model", {sizeof(rbdgrad_plan), kGradient, 0, 8, bodies_out},
       "model_desc.plan.fext_body_count is 8"},
      {"short struct", {8, kGradient, 0, 0, nullptr}, "model_desc.plan.struct_size is 8"},
  };
  for (const Case& c : cases) {
    rbdgrad_model_desc d = base.desc();
    d.plan = &c.plan;
    std::optional<BatchPlan> plan;
    const Status s = plan_from_desc(d, kAll, plan);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << c.what << ": " << s.message();
    EXPECT_THAT(s.message(), HasSubstr(c.message)) << c.what;
    EXPECT_FALSE(plan) << c.what;
  }
  // an output the backend does not compute
  const rbdgrad_plan tau{sizeof(rbdgrad_plan), RBDGRAD_OUTPUT_TAU, 0, 0, nullptr};
  rbdgrad_model_desc d = base.desc();
  d.plan = &tau;
  std::optional<BatchPlan> plan;
  const Status s = plan_from_desc(d, kGradient, plan);
  EXPECT_EQ(s.code(), StatusCode::kUnimplemented) << s.message();
  EXPECT_THAT(s.message(), HasSubstr("0x10 that this backend does not compute"));
}

TEST(BatchPlan, BatchesOutsideThePlanAreRefused) {
  const BatchPlan plan{RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQ, false, {}};
  double array[1] = {0};
  rbdgrad_batch b{};
  b.outputs = RBDGRAD_OUTPUT_DQDD_DQ;
  EXPECT_TRUE(check_batch_plan(b, plan).is_ok());
  b.outputs = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  EXPECT_THAT(check_batch_plan(b, plan).message(),
              HasSubstr("batch.outputs asks for flags 0x8 outside the instance's plan"));
  b.outputs = RBDGRAD_OUTPUT_DQDD_DQ;
  b.minv = array;
  EXPECT_THAT(check_batch_plan(b, plan).message(), HasSubstr("batch.minv is set"));
  b.minv = nullptr;
  b.fext = array;
  EXPECT_THAT(check_batch_plan(b, plan).message(), HasSubstr("batch.fext is set"));

  const BatchPlan cached{kGradient, true, {1}};
  b.fext = nullptr;
  EXPECT_THAT(check_batch_plan(b, cached).message(), HasSubstr("batch.minv is NULL"));
  b.minv = array;
  EXPECT_TRUE(check_batch_plan(b, cached).is_ok()) << "a batch without forces follows any plan";
  b.fext = array;
  EXPECT_TRUE(check_batch_plan(b, cached).is_ok());
}

TEST(BatchPlan, TheCorePlanReadsForcesOnThePlansBodiesOnly) {
  const BatchPlan plan{kGradient, false, {1, 4}};
  ExecutionPlan from_request;
  from_request.external_forces = ExternalForces::kAllBodies;
  const ExecutionPlan p = plan.execution_plan(from_request);
  ASSERT_EQ(p.external_forces, ExternalForces::kSomeBodies);
  EXPECT_EQ(p.fext_bodies.count(), 2);
  EXPECT_TRUE(p.fext_bodies.test(1));
  EXPECT_TRUE(p.fext_bodies.test(4));
  from_request.external_forces = ExternalForces::kNone;  // the batch brought no fext
  EXPECT_EQ(plan.execution_plan(from_request).external_forces, ExternalForces::kNone);
  EXPECT_TRUE(BatchPlan({kGradient, true, {}}).execution_plan(ExecutionPlan{}).minv_supplied);
}

}  // namespace
}  // namespace rbdgrad::plugin
