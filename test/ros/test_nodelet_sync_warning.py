#!/usr/bin/env python3
"""sync_warning.test: a stream of complete pairs, then one input stops while
the other three go on. The nodelet's "no synchronised stereo pair" warning
(on /rosout) must name that input as silent, and no other: first the right
image, then the right camera_info."""
import os
import sys
import unittest

import rospy
import rostest
from stereo_msgs.msg import DisparityImage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402

NS = "/sync"
INPUTS = ("left image", "right image", "left camera_info", "right camera_info")
TOPICS = (NS + "/left/image_rect", NS + "/right/image_rect", NS + "/left/camera_info", NS + "/right/camera_info")


class TestSyncWarning(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_nodelet_sync_warning")
        cls.left, cls.right = u.make_pair(seed=5)
        cls.rosout = u.RosoutWatcher("/manager")
        u.wait_nodelet_loaded(NS + "/bdis")
        cls.inputs = u.StereoInput(NS)
        cls.disparity = u.Collector(NS + "/disparity", DisparityImage)  # the nodelet subscribes for it
        cls.inputs.wait_connected()
        cls.stamps = u.StampSequence(100.0)

    def publish_frame(self, silent=None):
        """One frame on every input but `silent` (an index of INPUTS)."""
        stamp = self.stamps.next()
        msgs = (u.image_msg(self.left, stamp, u.LEFT_FRAME), u.image_msg(self.right, stamp, u.RIGHT_FRAME),
                u.info_msg(stamp, u.LEFT_FRAME), u.info_msg(stamp, u.RIGHT_FRAME, tx=-u.FX * u.BASELINE))
        for i, (pub, msg) in enumerate(zip(self.inputs.pubs, msgs)):
            if i != silent:
                pub.publish(msg)
        return stamp

    def pairs_flow(self):
        """Complete frames until one comes out as a disparity."""
        sent = []

        def publish():
            sent.append(self.publish_frame())
        u.publish_until(publish, lambda: any(self.disparity.with_stamp(s) for s in sent), 20.0,
                        "a disparity for complete frames", period=0.1)

    def warning_while_silent(self, silent):
        """Frames without input `silent` until the nodelet warns; the warning."""
        with self.rosout.lock:
            self.rosout.lines = []

        def publish():
            self.publish_frame(silent)
        lines = u.publish_until(publish, lambda: self.rosout.find("no synchronised stereo pair"), 20.0,
                                "the no-pair warning with the %s silent" % INPUTS[silent], period=0.1)
        return lines[0]

    def check_names_only(self, warning, silent):
        for i, (name, topic) in enumerate(zip(INPUTS, TOPICS)):
            text = "the %s (%s) is silent" % (name, topic)
            if i == silent:
                self.assertIn(text, warning)
            else:
                self.assertNotIn(text, warning)

    def test_1_right_image_stops(self):
        self.pairs_flow()
        warning = self.warning_while_silent(1)
        self.check_names_only(warning, 1)
        self.assertIn(" 0 right images (%s)" % TOPICS[1], warning)
        self.assertNotIn("camera_info missing", warning)

    def test_2_right_camera_info_stops(self):
        self.pairs_flow()
        warning = self.warning_while_silent(3)
        self.check_names_only(warning, 3)
        self.assertIn(" 0 right camera_infos (%s)" % TOPICS[3], warning)
        self.assertIn("camera_info missing", warning)


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_nodelet_sync_warning", TestSyncWarning)
