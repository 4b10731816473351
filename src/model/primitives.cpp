#include "retimegs/model/primitives.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "retimegs/core/error.hpp"

namespace retimegs::model {

template <typename T>
void reorder_rows(std::vector<T>& values, int width,
                  const std::vector<std::int32_t>& old_from_new) {
  const std::size_t rows = old_from_new.size();
  if (values.size() != rows * std::size_t(width))
    fail("reorder: {} values are not {} rows of {}", values.size(), rows, width);
  std::vector<T> out(values.size());
  const std::ptrdiff_t count = std::ptrdiff_t(rows);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < count; ++k)
    std::copy_n(&values[std::size_t(old_from_new[k]) * width], width, &out[std::size_t(k) * width]);
  values = std::move(out);
}

template void reorder_rows(std::vector<float>&, int, const std::vector<std::int32_t>&);
template void reorder_rows(std::vector<double>&, int, const std::vector<std::int32_t>&);

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
    if (!(p.tau_l[i] + p.tau_r[i] >= 0))
      fail("{}: primitive {} has an empty temporal window (tau_l + tau_r = {} < 0)", what, i,
           p.tau_l[i] + p.tau_r[i]);
}

}  // namespace retimegs::model
