#include "contrib_flow.hpp"

#include <opencv2/optflow.hpp>

#include "retimegs/core/error.hpp"

namespace retimegs::prepare::detail {

cv::Ptr<cv::DenseOpticalFlow> contrib_estimator(FlowMethod method) {
  switch (method) {
    case FlowMethod::kDeepFlow:
      return cv::optflow::createOptFlow_DeepFlow();
    case FlowMethod::kTvl1:
      return cv::optflow::DualTVL1OpticalFlow::create();
    case FlowMethod::kRlof:
      return cv::optflow::DenseRLOFOpticalFlow::create();
    case FlowMethod::kPcaFlow:
      return cv::optflow::createOptFlow_PCAFlow();
    default:
      fail("optical flow: {} is not an estimator of opencv_contrib's optflow",
           flow_method_name(method));
  }
}

}  // namespace retimegs::prepare::detail
