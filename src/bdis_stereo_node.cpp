// bdis_stereo_node: the BdisStereoNodelet as a plain node, for users without a
// nodelet manager. Same code, same topics and parameters (private ones under
// the node's name): the nodelet is loaded into an in-process loader.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "bdis_stereo");
  nodelet::Loader loader(false);  // no manager services: this process hosts one nodelet
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string nodelet_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "bdis_stereo/BdisStereoNodelet", remappings,
                   nodelet_argv)) {
    ROS_FATAL("could not load bdis_stereo/BdisStereoNodelet: is the workspace sourced?");
    return 1;
  }
  ros::spin();
  return 0;
}
