#pragma once
// The viewer data of `view` and `export --web`: the model read and packed with the scene's
// cameras and near plane (--near D overrides it).
#include <optional>
#include <string>

#include "retimegs/view/pack.hpp"

namespace retimegs::app {

view::Packed pack_for_web(const std::string& model_path, const std::string& scene_path,
                          const std::optional<double>& near);

}  // namespace retimegs::app
