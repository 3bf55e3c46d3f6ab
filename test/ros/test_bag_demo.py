#!/usr/bin/env python3
"""bag_demo.test: writes a tiny sequence in the dataset layout (left/, right/,
camera.yaml) to a temp dir, turns it into a bag with bdis_make_bag, checks the
bag, and replays it through demo.launch headless (a roslaunch child of this
test, on the test's master); the disparity must match the sequence's truth."""
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import cv2
import numpy as np
import rosbag
import rospy
import rostest
from stereo_msgs.msg import DisparityImage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402

FRAMES = 3


def write_sequence(root):
    os.makedirs(os.path.join(root, "left"))
    os.makedirs(os.path.join(root, "right"))
    for i in range(FRAMES):
        left, right = u.make_pair(seed=10 + i)
        cv2.imwrite(os.path.join(root, "left", "%06d.png" % i), left)
        cv2.imwrite(os.path.join(root, "right", "%06d.png" % i), right)
    u.common.write_camera(os.path.join(root, "camera.yaml"), u.W, u.H, u.FX, u.FX, u.CX, u.CY, u.BASELINE)


class TestBagDemo(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_bag_demo")
        cls.tmp = tempfile.mkdtemp(prefix="bdis_bag_demo_")
        cls.seq = os.path.join(cls.tmp, "seq")
        cls.bag = os.path.join(cls.tmp, "seq.bag")
        write_sequence(cls.seq)
        out = subprocess.run([u.common.find_program("bdis_make_bag"), cls.seq, cls.bag, "--rate", "5"],
                             capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        cls.tool_output = out.stdout

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_1_bag_has_the_four_topics_and_camera_info(self):
        self.assertIn("wrote %d frames" % FRAMES, self.tool_output)
        with rosbag.Bag(self.bag) as bag:
            info = bag.get_type_and_topic_info().topics
            self.assertEqual(sorted(info), ["/stereo/left/camera_info", "/stereo/left/image_rect",
                                            "/stereo/right/camera_info", "/stereo/right/image_rect",
                                            "/tf_static"])
            self.assertTrue(all(t.message_count == FRAMES for n, t in info.items() if n != "/tf_static"))
            self.assertEqual(info["/tf_static"].message_count, 1)
            stamps = {}
            for topic, msg, _, header in bag.read_messages(return_connection_header=True):
                if topic == "/tf_static":  # the rig: right optical frame at +baseline along x, latched
                    t = msg.transforms[0]
                    self.assertEqual((t.header.frame_id, t.child_frame_id),
                                     ("stereo_left_optical", "stereo_right_optical"))
                    self.assertAlmostEqual(t.transform.translation.x, u.BASELINE)
                    self.assertEqual(t.transform.rotation.w, 1.0)
                    self.assertIn(header.get("latching"), ("1", b"1"))
                    continue
                stamps.setdefault(topic, []).append(msg.header.stamp.to_sec())
                if topic == "/stereo/right/camera_info":
                    self.assertAlmostEqual(msg.P[3], -u.FX * u.BASELINE)
                    self.assertEqual((msg.width, msg.height), (u.W, u.H))
                if topic == "/stereo/left/image_rect":
                    self.assertEqual((msg.encoding, msg.width, msg.height), ("bgr8", u.W, u.H))
            for s in stamps.values():  # same stamps on all topics, 1 / rate apart
                self.assertEqual(s, stamps["/stereo/left/image_rect"])
                np.testing.assert_allclose(np.diff(s), 0.2, atol=1e-6)

    def test_2_bag_replays_through_demo_launch(self):
        disp = u.Collector("/stereo/disparity", DisparityImage)
        # Loop the bag so a slow start of the nodelet cannot make the test miss frames.
        log_path = os.path.join(self.tmp, "roslaunch.log")
        log = open(log_path, "w")
        proc = subprocess.Popen(["roslaunch", "bdis_stereo", "demo.launch", "bag:=" + self.bag,
                                 "loop:=true", "delay:=1", "rate:=2"],
                                stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            try:
                u.wait_for(lambda: disp.count() >= FRAMES + 1 or proc.poll() is not None, 60.0,
                           "disparities from the replayed bag")
                if proc.poll() is not None:
                    raise AssertionError("roslaunch exited with %s" % proc.returncode)
            except AssertionError:
                log.flush()
                with open(log_path) as f:
                    raise AssertionError("no disparity from demo.launch; its output:\n" + f.read()[-3000:])
            for m in list(disp.msgs):
                d = u.float_image(m.image)[8:-8, u.DISPARITY + 16:-8]
                self.assertGreater((np.abs(d - u.DISPARITY) < 0.5).mean(), 0.95)
                self.assertEqual(m.header.frame_id, "stereo_left_optical")
        finally:
            disp.close()
            u.common.stop_process_group(proc, timeout=20)
            log.close()


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_bag_demo", TestBagDemo)
