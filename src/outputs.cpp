#include "outputs.hpp"

#include <boost/make_shared.hpp>

namespace bdis_stereo {
namespace {

// The message in `slot` when nobody else holds it any more (roscpp has
// serialised it for every TCP subscriber and no intraprocess subscriber or
// queue keeps it), else a new one that takes the slot. Rewriting a reused
// message skips the zero-fill and page faults of fresh multi-megabyte
// buffers every frame; a message someone still holds is never touched.
template <typename M>
boost::shared_ptr<M> reusableMessage(boost::shared_ptr<M>& slot) {
  if (!slot || slot.use_count() != 1) slot = boost::make_shared<M>();
  return slot;
}

}  // namespace

void Outputs::advertise(ros::NodeHandle& nh, image_transport::ImageTransport& it,
                        const std::function<void()>& on_connection) {
  const auto ros_cb = [on_connection](const ros::SingleSubscriberPublisher&) { on_connection(); };
  const auto it_cb = [on_connection](const image_transport::SingleSubscriberPublisher&) { on_connection(); };
  disparity_pub_ = nh.advertise<stereo_msgs::DisparityImage>("disparity", 1, ros_cb, ros_cb);
  points_pub_ = nh.advertise<sensor_msgs::PointCloud2>("points2", 1, ros_cb, ros_cb);
  depth_pub_ = it.advertiseCamera("depth/image_rect", 1, it_cb, it_cb, ros_cb, ros_cb);
  confidence_pub_ = it.advertise("confidence", 1, it_cb, it_cb);
  variance_pub_ = it.advertise("variance", 1, it_cb, it_cb);
  disparity_image_pub_ = it.advertise("disparity_image", 1, it_cb, it_cb);
}

WantedOutputs Outputs::wanted() const {
  WantedOutputs w;
  w.disparity = disparity_pub_.getNumSubscribers() > 0;
  w.disparity_image = disparity_image_pub_.getNumSubscribers() > 0;
  w.depth = depth_pub_.getNumSubscribers() > 0;
  w.confidence = confidence_pub_.getNumSubscribers() > 0;
  w.variance = variance_pub_.getNumSubscribers() > 0;
  w.points = points_pub_.getNumSubscribers() > 0;
  return w;
}

void Outputs::publishDisparity(const std_msgs::Header& header, const cv::Mat& disparity,
                               const bdis::StereoCamera& camera, const WantedOutputs& wanted) {
  const stereo_msgs::DisparityImagePtr msg = reusableMessage(disparity_msg_);
  msg->header = header;
  msg->image.header = header;
  fillDisparityImage(disparity, camera, *msg);
  if (wanted.disparity_image) {
    const sensor_msgs::ImagePtr image = reusableMessage(disparity_image_msg_);
    *image = msg->image;
    disparity_image_pub_.publish(image);
  }
  if (wanted.disparity) disparity_pub_.publish(msg);
}

cv::Mat Outputs::publishDepth(const std_msgs::Header& header, const cv::Mat& disparity,
                              const bdis::StereoCamera& camera, const sensor_msgs::CameraInfo& left_info) {
  const sensor_msgs::ImagePtr msg = reusableMessage(depth_msg_);
  msg->header = header;
  fillDepthImage(disparity, camera, *msg);
  sensor_msgs::CameraInfoPtr info(new sensor_msgs::CameraInfo(left_info));
  info->header = header;
  depth_pub_.publish(msg, info);
  return cv::Mat(static_cast<int>(msg->height), static_cast<int>(msg->width), CV_32FC1, msg->data.data(),
                 msg->step);
}

void Outputs::publishConfidence(const std_msgs::Header& header, const cv::Mat& confidence) {
  const sensor_msgs::ImagePtr msg = reusableMessage(confidence_msg_);
  msg->header = header;
  fillFloatImage(confidence, *msg);
  confidence_pub_.publish(msg);
}

void Outputs::publishVariance(const std_msgs::Header& header, const cv::Mat& variance) {
  const sensor_msgs::ImagePtr msg = reusableMessage(variance_msg_);
  msg->header = header;
  fillFloatImage(variance, *msg);
  variance_pub_.publish(msg);
}

void Outputs::publishPoints(const std_msgs::Header& header, const cv::Mat& depth,
                            const bdis::StereoCamera& camera, const cv::Mat& left_bgr, bool organized,
                            const RigidTransform* transform, const std::string& target_frame) {
  const sensor_msgs::PointCloud2Ptr msg = reusableMessage(points_msg_);
  msg->header = header;
  if (transform) msg->header.frame_id = target_frame;
  fillPointCloudFromDepth(depth, camera, left_bgr, organized, transform, *msg);
  points_pub_.publish(msg);
}

}  // namespace bdis_stereo
