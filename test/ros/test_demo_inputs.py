#!/usr/bin/env python3
"""demo_inputs.test: bdis_demo (its own master, its own nodelet) on
compressed and raw input. A tiny sequence in the data layout with exact
ground truth is replayed with --compress and --distort together (raw JPEG
frames: the nodelet decodes them and image_proc/rectify undistorts them), and
as a bag whose compressed topics live elsewhere, named with --left-image etc.
Every frame must come out, none rejected, and the accuracy be scored."""
import json
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

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402

FRAMES = 4


def write_sequence(root):
    for d in ("left", "right", "gt_disparity"):
        os.makedirs(os.path.join(root, d))
    gt = np.zeros((u.H, u.W), np.uint16)
    gt[:, u.DISPARITY:] = u.DISPARITY * 256  # KITTI: d * 256, 0 = unknown
    for i in range(FRAMES):
        left, right = u.make_pair(seed=20 + i)
        name = "%06d.png" % i
        cv2.imwrite(os.path.join(root, "left", name), left)
        cv2.imwrite(os.path.join(root, "right", name), right)
        cv2.imwrite(os.path.join(root, "gt_disparity", name), gt)
    u.common.write_camera(os.path.join(root, "camera.yaml"), u.W, u.H, u.FX, u.FX, u.CX, u.CY, u.BASELINE)


class TestDemoInputs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_demo_inputs")
        cls.tmp = tempfile.mkdtemp(prefix="bdis_demo_inputs_")
        cls.seq = os.path.join(cls.tmp, "seq")
        write_sequence(cls.seq)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def demo(self, name, *args):
        out = os.path.join(self.tmp, name)
        run = subprocess.run([u.common.find_program("bdis_demo"), "--out", out, "--rate", "5"] + list(args),
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=240)
        print(run.stdout)
        self.assertEqual(run.returncode, 0, run.stdout[-3000:])
        with open(os.path.join(out, "report.json")) as f:
            report = json.load(f)
        self.assertEqual(report["frames_out"], FRAMES)
        self.assertEqual(report["nodelet"].get("rejected"), "0")
        self.assertEqual(report["nodelet"].get("errors"), "0")
        return run.stdout, report

    def test_1_folder_as_raw_compressed_frames(self):
        text, report = self.demo("raw_jpeg", "--data", self.seq, "--compress", "jpeg:95", "--distort=-0.1,0.01")
        self.assertIn("raw images, rectified by image_proc/rectify, compressed", text)
        self.assertIn("rectify:=true image_transport:=compressed", text)
        bdis = report["accuracy"]["predictions"]
        self.assertEqual(bdis["frames"], FRAMES)
        self.assertGreater(bdis["density"], 0.8)
        self.assertLess(bdis["median_error"], 0.3)

    def test_2_bag_with_compressed_topics_elsewhere(self):
        bag = os.path.join(self.tmp, "cam.bag")
        make = subprocess.run([u.common.find_program("bdis_make_bag"), self.seq, bag, "--ns", "/cam",
                               "--compress", "png", "--rate", "5"],  # as the folder: slow enough for any build
                              capture_output=True, text=True, timeout=60)
        self.assertEqual(make.returncode, 0, make.stderr)
        with rosbag.Bag(bag) as b:
            self.assertIn("/cam/left/image_rect/compressed", b.get_type_and_topic_info().topics)
        text, _ = self.demo("bag_png", "--bag", bag, "--left-image", "/cam/left/image_rect",
                            "--right-image", "/cam/right/image_rect/compressed", "--left-info", "/cam/left/camera_info",
                            "--right-info", "/cam/right/camera_info")
        self.assertIn("rectified images, compressed", text)


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_demo_inputs", TestDemoInputs)
