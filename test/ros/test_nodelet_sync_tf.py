#!/usr/bin/env python3
"""sync_tf.test: /approx/bdis (approximate_sync) pairs offset stamps;
/tf/bdis (target_frame: world) publishes the cloud in the camera frame with a
warning while no transform exists, then transformed once /tf_static has one."""
import math
import os
import sys
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import PointCloud2
from stereo_msgs.msg import DisparityImage
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402


class TestSyncTf(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_nodelet_sync_tf")
        cls.left, cls.right = u.make_pair(seed=3)
        cls.rosout = u.RosoutWatcher("/manager")
        for n in ("/approx/bdis", "/tf/bdis"):
            u.wait_nodelet_loaded(n)

    def test_approximate_sync_pairs_offset_stamps(self):
        inputs = u.StereoInput("/approx")
        disp = u.Collector("/approx/disparity", DisparityImage)
        try:
            inputs.wait_connected()
            # A stream, as from a camera: approximate sync decides on a set
            # once a newer message has arrived on every topic.
            sent = []

            def publish_next():
                stamp = rospy.Time(200, 0) + rospy.Duration(0.1 * len(sent))
                sent.append(stamp)
                inputs.publish_pair(stamp, self.left, self.right, right_stamp=stamp + rospy.Duration(0.004))

            msg = u.publish_until(publish_next, lambda: next(
                (m for s in sent for m in [disp.with_stamp(s)] if m is not None), None),
                20.0, "a disparity for offset stamps", period=0.1)
            self.assertEqual(msg.header.frame_id, u.LEFT_FRAME)  # left stamp and frame
            d = u.float_image(msg.image)[8:-8, u.DISPARITY + 16:-8]
            self.assertGreater((np.abs(d - u.DISPARITY) < 0.5).mean(), 0.95)
        finally:
            disp.close()

    def test_approximate_sync_after_a_jump_back(self):
        """A looping bag: the stamps go back 10 s, with the right camera 4 ms
        behind the left and the last left images unpaired; new sets form at
        once."""
        inputs = u.StereoInput("/approx")
        disp = u.Collector("/approx/disparity", DisparityImage)
        try:
            inputs.wait_connected()
            for start in (300.0, 290.0, 280.0):
                sent = []

                def publish_next():
                    stamp = rospy.Time.from_sec(start) + rospy.Duration(0.1 * len(sent))
                    sent.append(stamp)
                    inputs.publish_pair(stamp, self.left, self.right, right_stamp=stamp + rospy.Duration(0.004))

                msg = u.publish_until(publish_next, lambda: next(
                    (m for s in sent for m in [disp.with_stamp(s)] if m is not None), None),
                    20.0, "a disparity after the stamps moved to %.0f s" % start, period=0.1)
                d = u.float_image(msg.image)[8:-8, u.DISPARITY + 16:-8]
                self.assertGreater((np.abs(d - u.DISPARITY) < 0.5).mean(), 0.95)
                for _ in range(5):  # more of this stream before the next jump
                    publish_next()
                    rospy.sleep(0.1)
                for k in range(3):  # and left images whose right partners were lost
                    stamp = sent[-1] + rospy.Duration(0.1 * (k + 1))
                    inputs.pubs[0].publish(u.image_msg(self.left, stamp))
                    inputs.pubs[2].publish(u.info_msg(stamp))
            self.assertGreaterEqual(len(self.rosout.find("synchroniser reset")), 2)
        finally:
            disp.close()

    def test_target_frame_with_and_without_transform(self):
        inputs = u.StereoInput("/tf")
        cloud = u.Collector("/tf/points2", PointCloud2)
        tf_pub = rospy.Publisher("/tf_static", TFMessage, queue_size=1, latch=True)
        try:
            inputs.wait_connected()
            # No transform yet: camera frame and a warning; never blocks.
            stamp = rospy.Time(300, 0)
            cam = u.publish_until(lambda: inputs.publish_pair(stamp, self.left, self.right),
                                  lambda: cloud.with_stamp(stamp), 20.0, "a cloud without tf")
            self.assertEqual(cam.header.frame_id, u.LEFT_FRAME)
            self.rosout.wait_text("no transform world <- " + u.LEFT_FRAME)
            # world <- camera: 90 degrees about z, then (1, 2, 3).
            t = TransformStamped()
            t.header.stamp = rospy.Time(0)
            t.header.frame_id = "world"
            t.child_frame_id = u.LEFT_FRAME
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = 1.0, 2.0, 3.0
            t.transform.rotation.z = math.sin(math.pi / 4)
            t.transform.rotation.w = math.cos(math.pi / 4)
            tf_pub.publish(TFMessage(transforms=[t]))
            stamp = rospy.Time(301, 0)
            world = u.publish_until(
                lambda: inputs.publish_pair(stamp, self.left, self.right),
                lambda: self._newer_world(cloud, stamp), 20.0, "a cloud in world")
            self.assertEqual(world.header.frame_id, "world")
            p = u.cloud_array(cam)
            q = u.cloud_array(world)
            valid = ~np.isnan(p["z"])
            self.assertGreater(valid.mean(), 0.8)
            np.testing.assert_array_equal(np.isnan(q["z"]), ~valid)
            # Same pair, same matcher: world point = R * camera point + t.
            np.testing.assert_allclose(q["x"][valid], -p["y"][valid] + 1.0, atol=1e-4)
            np.testing.assert_allclose(q["y"][valid], p["x"][valid] + 2.0, atol=1e-4)
            np.testing.assert_allclose(q["z"][valid], p["z"][valid] + 3.0, atol=1e-4)
        finally:
            cloud.close()

    @staticmethod
    def _newer_world(cloud, after):
        with cloud.lock:
            for m in cloud.msgs:
                if m.header.stamp >= after and m.header.frame_id == "world":
                    return m
        return None


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_nodelet_sync_tf", TestSyncTf)
