// The service's descriptions (ListModels, GetModel, GetServerInfo responses) as the API's plain
// structs. Private to the client library.
#pragma once

#include <vector>

#include "rbdgrad/service_info.hpp"
#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::detail {

std::vector<ServedModel> decode(const v1::ListModelsResponse& r);
ModelDescription decode(const v1::GetModelResponse& r);
SceneDescription decode(const v1::Scene& r);
ServerInfo decode(const v1::GetServerInfoResponse& r);

}  // namespace rbdgrad::detail
