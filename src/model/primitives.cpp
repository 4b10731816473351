#include "retimegs/model/primitives.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"

namespace retimegs::model {

void check_primitives(const Primitives& p, const std::string& what) {
  const std::size_t n = p.size();
  for (const auto& field : p.fields()) {
    if (field.values->size() != n * field.width)
      fail("{}: field '{}' has {} values, expected {} ({} primitives x {})", what, field.name,
           field.values->size(), n * field.width, n, field.width);
    for (std::size_t k = 0; k < field.values->size(); ++k)
      if (!std::isfinite((*field.values)[k]))
        fail("{}: field '{}' of primitive {} is not finite", what, field.name, k / field.width);
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!(p.tau_l[i] >= 0 && p.tau_r[i] >= 0))
      fail("{}: primitive {} has a negative temporal half-width", what, i);
}

}  // namespace retimegs::model
