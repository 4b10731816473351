#pragma once
// The flow estimators of opencv_contrib's optflow module (deepflow, tvl1, rlof, pcaflow):
// contrib_flow.cpp, or without_optflow/ in the lean GPU build (RETIMEGS_GPU_ONLY), whose OpenCV
// has core, imgproc and video only (optflow needs imgcodecs, whose dependencies are more than a
// bare GPU machine may be brought). DIS and Farneback, in video, are in every build.
#include <opencv2/video/tracking.hpp>

#include "retimegs/prepare/flow_estimate.hpp"

namespace retimegs::prepare::detail {

// The estimator of `method`, one of kDeepFlow, kTvl1, kRlof, kPcaFlow. Throws Error naming the
// method when this build has none.
cv::Ptr<cv::DenseOpticalFlow> contrib_estimator(FlowMethod method);

}  // namespace retimegs::prepare::detail
