// The lean GPU build (RETIMEGS_GPU_ONLY) has no opencv_contrib optflow: its estimators name what
// is missing and the ones this build has.
#include "../contrib_flow.hpp"

#include "retimegs/core/error.hpp"

namespace retimegs::prepare::detail {

cv::Ptr<cv::DenseOpticalFlow> contrib_estimator(FlowMethod method) {
  fail(
      "--flow {}: needs opencv_contrib's optflow, which the lean GPU build has not; the DIS "
      "variants and farneback are built in",
      flow_method_name(method));
}

}  // namespace retimegs::prepare::detail
