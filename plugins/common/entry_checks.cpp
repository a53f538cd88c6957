#include "entry_checks.hpp"

#include <cstddef>
#include <string>

namespace rbdgrad::plugin {

Status check_struct_size(const char* what, std::size_t got, std::size_t want) {
  if (got >= want) return Status::ok();
  return invalid_argument(std::string(what) + ".struct_size is " + std::to_string(got) + ", expected at least " +
                          std::to_string(want));
}

Status check_info(const rbdgrad_plugin_info* info) {
  if (info == nullptr) return invalid_argument("info is NULL");
  return check_struct_size("info", info->struct_size, sizeof(rbdgrad_plugin_info));
}

Status check_instance_info(const rbdgrad_instance_info* info) {
  if (info == nullptr) return invalid_argument("info is NULL");
  return check_struct_size("instance_info", info->struct_size, offsetof(rbdgrad_instance_info, detail));
}

bool instance_info_has_detail(const rbdgrad_instance_info& info) {
  return info.struct_size >= offsetof(rbdgrad_instance_info, detail) + sizeof(info.detail);
}

Status check_can_run_question(const rbdgrad_model_desc* model, std::uint64_t n) {
  if (model == nullptr) return invalid_argument("model is NULL");
  if (Status s = check_struct_size("model_desc", model->struct_size, offsetof(rbdgrad_model_desc, plan)); !s) return s;
  if (model->nv < 1) return invalid_argument("model_desc.nv is 0");
  if (n < 1) return invalid_argument("n is 0: a batch holds at least one state");
  return Status::ok();
}

}  // namespace rbdgrad::plugin
