#include "frame_pipeline.hpp"

#include <sstream>
#include <utility>

#include <geometry_msgs/TransformStamped.h>
#include <opencv2/imgproc.hpp>

#include "bdis_stereo/pair_check.hpp"
#include "ros_frame.hpp"

namespace bdis_stereo {

FramePipeline::FramePipeline(std::string log_name, const NodeParams& params,
                             const bdis::MatcherParams& matcher_params, ros::NodeHandle& nh, Outputs& outputs,
                             NodeStatistics& statistics, MatcherReconfigure& reconfigure)
    : log_name_(std::move(log_name)),
      params_(params),
      outputs_(outputs),
      statistics_(statistics),
      reconfigure_(reconfigure),
      matcher_(matcher_params) {
  if (!params_.target_frame.empty()) {
    tf_buffer_.reset(new tf2_ros::Buffer(ros::Duration(10.0)));
    tf_listener_.reset(new tf2_ros::TransformListener(*tf_buffer_, nh));
  }
}

void FramePipeline::process(const StereoFrame& frame) {
  noteStamp(frame.leftHeader().stamp);
  const ros::WallTime start = ros::WallTime::now();  // decoding is part of the frame's processing
  // Validate before anything that asserts or throws sees the frame.
  InputImages images;
  bdis::StereoCamera camera;
  std::string error = inputImages(frame, images);
  if (error.empty()) error = validate(images, frame, camera);
  if (!error.empty()) {
    reject(error);
    return;
  }
  const WantedOutputs wanted = outputs_.wanted();  // compute only what is wanted
  if (!wanted.any()) return;
  bdis::MatcherParams changed;
  if (reconfigure_.takeChange(changed)) matcher_.setParams(changed);  // validated by reconfigure_

  const MatcherInput input = matcherInput(images);
  if (camerasLookSwapped(input, start)) return;
  checkInputCoding(input.left, start);
  bdis::MatchOutputs maps;
  maps.confidence = wanted.confidence;
  maps.variance = wanted.variance;
  matcher_.compute(input.left, input.right, result_, maps);
  publish(images.left->header, *frame.left_info, camera, input, wanted);

  const ros::WallTime end = ros::WallTime::now();
  statistics_.frameOut((end - start).toSec() * 1e3, (end - frame.arrival).toSec() * 1e3);
}

void FramePipeline::noteStamp(const ros::Time& stamp) {
  if (!last_stamp_.isZero() && stamp < last_stamp_) {
    // Time went back (InputSync has said so): transforms stamped in the
    // "future" would serve the new frames wrongly, and the new stream
    // (another bag?) gets its cameras checked at once.
    if (tf_buffer_) tf_buffer_->clear();
    last_sign_check_ = ros::WallTime();
    last_coding_check_ = ros::WallTime();
  }
  last_stamp_ = stamp;
}

std::string FramePipeline::inputImages(const StereoFrame& frame, InputImages& images) {
  const auto max_pixels = static_cast<std::size_t>(params_.max_image_pixels);
  images.left = frame.left.get();
  images.right = frame.right.get();
  if (frame.left_compressed) {
    const std::string error = decodeCompressedImage(*frame.left_compressed, "left", max_pixels, decoded_left_);
    if (!error.empty()) return error;
    images.left = &decoded_left_;
  }
  if (frame.right_compressed) {
    const std::string error = decodeCompressedImage(*frame.right_compressed, "right", max_pixels, decoded_right_);
    if (!error.empty()) return error;
    images.right = &decoded_right_;
  }
  return "";
}

std::string FramePipeline::validate(const InputImages& images, const StereoFrame& frame,
                                    bdis::StereoCamera& camera) const {
  const auto max_pixels = static_cast<std::size_t>(params_.max_image_pixels);
  std::string error = checkImage(*images.left, "left", max_pixels);
  if (error.empty()) error = checkImage(*images.right, "right", max_pixels);
  if (error.empty()) error = checkImagePair(*images.left, *images.right);
  if (error.empty()) {
    error = stereoCameraFromInfo(*frame.left_info, *frame.right_info, static_cast<int>(images.left->width),
                                 static_cast<int>(images.left->height), camera);
  }
  return error;
}

FramePipeline::MatcherInput FramePipeline::matcherInput(const InputImages& images) {
  MatcherInput input;
  input.left = matcherView(*images.left, left_buffer_);
  input.right = matcherView(*images.right, right_buffer_);
  if (input.left.channels() == 3) input.left_colour = input.left;
  if (input.left.channels() != input.right.channels()) {  // one mono, one colour: match in grey
    cv::Mat& colour = input.left.channels() == 3 ? input.left : input.right;
    cv::cvtColor(colour, grey_buffer_, cv::COLOR_BGR2GRAY);
    colour = grey_buffer_;
  }
  return input;
}

// Swapped cameras with correct camera_infos pass every check of validate();
// the matcher (d >= 0 only) would publish garbage. A coarse search of both
// signs tells (about 2 ms at 640x480): on the first frame, then once a second
// (a swap is a setup error, there from the start) and on every frame while it fails.
bool FramePipeline::camerasLookSwapped(const MatcherInput& input, ros::WallTime now) {
  if (!looks_swapped_ && (now - last_sign_check_).toSec() < kInputCheckPeriod) return false;
  const bdis::DisparitySignCheck sign = bdis::checkDisparitySign(input.left, input.right);
  last_sign_check_ = now;
  looks_swapped_ = sign.looksSwapped();
  if (looks_swapped_) {
    std::ostringstream os;
    os << sign.negative << " of " << sign.distinct_patches
       << " distinct matches lie at negative disparity (the scene is further right in the left image "
          "than in the right one): are the cameras swapped? Check the left/right topic remaps";
    reject(os.str());
  }
  return looks_swapped_;
}

// A block codec (JPEG, MPEG) upstream removes texture the matcher needs and
// leaves its 8 x 8 grid, fixed in the image, which no single result shows:
// said once when it appears (and when it goes), kept in the diagnostics. About
// 1 ms at 640x480, once a second.
void FramePipeline::checkInputCoding(const cv::Mat& left, ros::WallTime now) {
  if ((now - last_coding_check_).toSec() < kInputCheckPeriod) return;
  last_coding_check_ = now;
  const bdis::BlockArtefactCheck check = bdis::checkBlockArtefacts(left);
  statistics_.inputBlockGrid(check);
  if (check.looksBlockCompressed() == block_coded_) return;
  block_coded_ = check.looksBlockCompressed();
  if (block_coded_) {
    ROS_WARN_NAMED(log_name_,
                   "the left image carries a block codec's 8 x 8 grid (grey steps across it %.1f times those "
                   "elsewhere): it was JPEG- or video-coded, which removes texture the matcher needs. Expect more "
                   "wrong depths in dark and flat tissue (on generated dark tissue 6 %% of the depths are wrong "
                   "uncompressed, 7 %% at JPEG quality 90, 13 %% at 80, 20 %% at 75): stream raw or PNG images, or JPEG "
                   "at quality 90 or more",
                   check.grid_contrast);
  } else {
    ROS_INFO_NAMED(log_name_, "the left image no longer carries a block codec's grid (%.2f)", check.grid_contrast);
  }
}

// Every output carries the left image's stamp and frame.
void FramePipeline::publish(const std_msgs::Header& header, const sensor_msgs::CameraInfo& left_info,
                            const bdis::StereoCamera& camera, const MatcherInput& input, const WantedOutputs& wanted) {
  if (wanted.disparity || wanted.disparity_image) {
    outputs_.publishDisparity(header, result_.disparity, camera, wanted);
  }
  // The depth image: the published message's when there is one, else
  // computed for points2 alone.
  cv::Mat depth;
  if (wanted.depth) depth = outputs_.publishDepth(header, result_.disparity, camera, left_info);
  if (wanted.confidence) outputs_.publishConfidence(header, result_.confidence);
  if (wanted.variance && !result_.variance.empty()) outputs_.publishVariance(header, result_.variance);
  if (wanted.points) publishPoints(header, depth, camera, input.left_colour);
}

void FramePipeline::publishPoints(const std_msgs::Header& header, cv::Mat depth,
                                  const bdis::StereoCamera& camera, const cv::Mat& left_colour) {
  RigidTransform transform;
  const bool transformed = cloudTransform(header, transform);
  const int stride = params_.cloudStrideFor(result_.disparity.cols);
  cv::Mat colour = left_colour;
  if (stride > 1) {
    // Depth at the kept pixels only; the published depth image's when there is one.
    if (depth.empty()) {
      bdis::subsample(result_.disparity, stride, cloud_disparity_);
      bdis::disparityToDepth(cloud_disparity_, camera, depth_buffer_);
    } else {
      bdis::subsample(depth, stride, depth_buffer_);
    }
    depth = depth_buffer_;
    if (!colour.empty()) {
      bdis::subsample(left_colour, stride, cloud_colour_);
      colour = cloud_colour_;
    }
  } else if (depth.empty()) {
    bdis::disparityToDepth(result_.disparity, camera, depth_buffer_);
    depth = depth_buffer_;
  }
  outputs_.publishPoints(header, depth, camera.subsampled(stride), colour, params_.organized_cloud,
                         transformed ? &transform : nullptr, params_.target_frame);
}

// The transform into target_frame at the image's stamp, waiting at most
// tf_timeout; false (and a throttled warning) without one: the cloud then
// stays in the camera frame.
bool FramePipeline::cloudTransform(const std_msgs::Header& header, RigidTransform& transform) const {
  if (params_.target_frame.empty() || params_.target_frame == header.frame_id) return false;
  std::string error;
  try {
    const geometry_msgs::TransformStamped tf = tf_buffer_->lookupTransform(
        params_.target_frame, header.frame_id, header.stamp, ros::Duration(params_.tf_timeout));
    error = rigidTransformFromTf(tf, transform);
  } catch (const tf2::TransformException& e) {
    error = e.what();
  }
  if (error.empty()) return true;
  ROS_WARN_THROTTLE_NAMED(5.0, log_name_, "no transform %s <- %s at %.3f (%s): publishing points2 in %s",
                          params_.target_frame.c_str(), header.frame_id.c_str(), header.stamp.toSec(),
                          error.c_str(), header.frame_id.c_str());
  return false;
}

void FramePipeline::reject(const std::string& what) {
  if (statistics_.rejected(what)) ROS_ERROR_NAMED(log_name_, "frame dropped: %s", what.c_str());
}

}  // namespace bdis_stereo
