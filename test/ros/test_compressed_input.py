#!/usr/bin/env python3
"""compressed_input.test: the nodelet with image_transport compressed, loaded
by this test (so that its start-up log is seen) into the test's manager. Where
compressed_image_transport is not installed (Debian 12) the nodelet subscribes
to <image topic>/compressed and decodes JPEG and PNG itself; where it is
(Noetic), the plugin decodes. Either way it says once which. PNG frames give
the raw path's disparity, JPEG frames nearly; a truncated or corrupt JPEG, a
16-bit PNG or data that is no image is a dropped frame with a clear message,
logged once however often it comes (throttled), the next good frame goes out
and the manager lives. JPEG at a low quality is said once (its 8 x 8 grid), and
shown in the diagnostics while it lasts."""
import os
import subprocess
import sys
import unittest

import cv2
import numpy as np
import rosgraph
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from sensor_msgs.msg import CameraInfo, CompressedImage
from stereo_msgs.msg import DisparityImage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402

MANAGER = "/stereo/manager"
NODELET = "/stereo/bdis"
STAMPS = u.StampSequence(300.0)
BUILTIN = "decoding JPEG and PNG with OpenCV (built-in decoding)"
PLUGIN = "decoding through the compressed_image_transport plugin"
GRID = "carries a block codec's 8 x 8 grid"
NO_GRID = "no longer carries a block codec's grid"
# Not a multiple of JPEG's 8 px blocks: the right image's blocks hold other
# content than the left's, so JPEG's losses differ between them.
DISPARITY = 7


def compressed(array, stamp, frame_id, compression="png"):
    return u.common.compressed_image_msg(array, frame_id, compression, stamp)


def with_data(msg, data):
    msg.data = bytes(data)
    return msg


def truncated_jpeg(array, stamp, frame_id):
    msg = compressed(array, stamp, frame_id, "jpeg:95")
    return with_data(msg, msg.data[:len(msg.data) * 2 // 3])


def corrupt_jpeg(array, stamp, frame_id):
    """The scan names a component the frame has not: libjpeg gives up."""
    msg = compressed(array, stamp, frame_id, "jpeg:95")
    data = bytearray(msg.data)
    scan = data.find(b"\xff\xda")
    data[scan + 5] = 0x77
    return with_data(msg, data)


def png16(array, stamp, frame_id):
    grey = array if array.ndim == 2 else cv2.cvtColor(array, cv2.COLOR_BGR2GRAY)
    ok, data = cv2.imencode(".png", grey.astype(np.uint16) * 257)
    msg = compressed(array, stamp, frame_id)
    msg.format = "mono16; png compressed "
    return with_data(msg, data.tobytes())


def weak_pair(d=DISPARITY):
    """Weakly textured tissue (grey 60..100): where a codec's blocks show."""
    rng = np.random.default_rng(9)
    tex = cv2.GaussianBlur(rng.random((u.H, u.W + d)).astype(np.float32), (0, 0), 3.0)
    tex = cv2.normalize(tex, None, 60, 100, cv2.NORM_MINMAX).astype(np.uint8)
    return tuple(cv2.cvtColor(a, cv2.COLOR_GRAY2BGR) for a in (tex[:, :u.W].copy(), tex[:, d:d + u.W].copy()))


class TestCompressedInput(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_compressed_input")
        cls.rosout = u.RosoutWatcher(MANAGER)
        cls.pubs = [rospy.Publisher("/stereo/left/image_rect/compressed", CompressedImage, queue_size=10),
                    rospy.Publisher("/stereo/right/image_rect/compressed", CompressedImage, queue_size=10),
                    rospy.Publisher("/stereo/left/camera_info", CameraInfo, queue_size=10),
                    rospy.Publisher("/stereo/right/camera_info", CameraInfo, queue_size=10)]
        u.wait_for(lambda: rosgraph.Master("/test").lookupNode(MANAGER), 30.0, "the manager")
        u.wait_for(lambda: cls.rosout.sub.get_num_connections() > 0, 10.0, "/rosout")
        rospy.sleep(0.5)  # the manager's connection to this /rosout subscriber
        # Loaded here, not in the .test, so that its start-up lines reach /rosout after we listen.
        cls.loader = subprocess.Popen(
            ["rosrun", "nodelet", "nodelet", "load", "bdis_stereo/BdisStereoNodelet", MANAGER, "__name:=bdis",
             "__ns:=/stereo", "_image_transport:=compressed"], stdin=subprocess.DEVNULL)
        u.wait_nodelet_loaded(NODELET)
        cls.disparity = u.Collector("/stereo/disparity", DisparityImage)
        u.wait_for(lambda: all(p.get_num_connections() > 0 for p in cls.pubs), 20.0,
                   "the nodelet to subscribe to the compressed images and camera_infos")
        cls.left, cls.right = u.make_pair(seed=5, d=DISPARITY)

    @classmethod
    def tearDownClass(cls):
        cls.disparity.close()
        cls.loader.send_signal(2)  # SIGINT: the loader unloads the nodelet
        try:
            cls.loader.wait(timeout=20)
        except subprocess.TimeoutExpired:
            cls.loader.kill()

    def builtin(self):
        return bool(u.wait_for(lambda: self.rosout.find(BUILTIN) or self.rosout.find(PLUGIN), 15.0,
                               "the line saying how the images are decoded") and self.rosout.find(BUILTIN))

    def publish(self, stamp, left_msg, right_msg):
        infos = (u.info_msg(stamp, u.LEFT_FRAME), u.info_msg(stamp, u.RIGHT_FRAME, tx=-u.FX * u.BASELINE))
        for pub, msg in zip(self.pubs, (left_msg, right_msg) + infos):
            pub.publish(msg)

    def processed(self, make_left, make_right, left=None, right=None):
        """Publishes a frame (again every 0.5 s, same stamp) until its disparity
        is out; returns the disparity image."""
        left = self.left if left is None else left
        right = self.right if right is None else right
        stamp = STAMPS.next()
        msg = u.publish_until(
            lambda: self.publish(stamp, make_left(left, stamp, u.LEFT_FRAME), make_right(right, stamp, u.RIGHT_FRAME)),
            lambda: self.disparity.with_stamp(stamp), 20.0, "disparity with stamp %.3f" % stamp.to_sec())
        return u.float_image(msg.image)

    def good(self):
        return self.processed(compressed, compressed)

    def test_1_says_once_how_it_decodes(self):
        self.good()
        builtin = self.builtin()
        print("decoding: %s" % ("built-in" if builtin else "plugin"))
        self.assertEqual(len(self.rosout.find(BUILTIN)) + len(self.rosout.find(PLUGIN)), 1)

    def test_2_png_is_the_raw_path_and_jpeg_close(self):
        inner = (slice(8, u.H - 8), slice(DISPARITY + 16, u.W - 8))  # textured, matchable
        for name, compression, mono, median_px, within in (
                ("png", "png", False, 0.1, 0.97), ("jpeg 95", "jpeg:95", False, 0.2, 0.9),
                ("mono jpeg 90", "jpeg:90", True, 0.2, 0.9)):
            left, right = self.left, self.right
            if mono:
                left, right = (cv2.cvtColor(a, cv2.COLOR_BGR2GRAY) for a in (left, right))
            d = self.processed(lambda a, s, f: compressed(a, s, f, compression),
                               lambda a, s, f: compressed(a, s, f, compression), left, right)
            self.assertEqual(d.shape, (u.H, u.W))
            valid = d[inner] >= 0
            err = np.abs(d[inner][valid] - DISPARITY)
            print("%s: density %.3f, median error %.3f px, within 0.5 px %.3f"
                  % (name, valid.mean(), np.median(err), (err < 0.5).mean()))
            self.assertGreater(valid.mean(), 0.9, name)
            self.assertLess(np.median(err), median_px, name)
            self.assertGreater((err < 0.5).mean(), within, name)

    def diagnostics(self):
        got = []
        sub = rospy.Subscriber("/diagnostics", DiagnosticArray, lambda m: got.extend(
            (s.level, s.message, {kv.key: kv.value for kv in s.values}) for s in m.status if NODELET in s.name))
        try:
            return u.wait_for(lambda: got and got[-1], 10.0, "diagnostics of " + NODELET)
        finally:
            sub.unregister()

    def frames_for(self, seconds, compression, left, right):
        """Frames of `compression` for longer than the grid check's period."""
        end = rospy.get_time() + seconds
        while rospy.get_time() < end:
            self.processed(lambda a, s, f: compressed(a, s, f, compression),
                           lambda a, s, f: compressed(a, s, f, compression), left, right)

    def test_4_block_coded_input_is_said_once_and_diagnosed(self):
        left, right = weak_pair()
        self.frames_for(2.5, "png", left, right)  # whatever came before is over
        said, cleared = len(self.rosout.find(GRID)), len(self.rosout.find(NO_GRID))
        self.frames_for(2.5, "jpeg:75", left, right)
        u.wait_for(lambda: len(self.rosout.find(GRID)) > said, 10.0, "a new log line containing %r" % GRID)
        self.frames_for(1.5, "jpeg:75", left, right)
        self.assertEqual(len(self.rosout.find(GRID)), said + 1, "said once while it lasts")
        level, message, values = self.diagnostics()
        print("JPEG 75: input_block_grid %s, %r" % (values["input_block_grid"], message))
        self.assertGreaterEqual(float(values["input_block_grid"]), 1.2)
        self.assertEqual(level, DiagnosticStatus.WARN)
        self.assertIn("block-coded", message)
        self.frames_for(2.5, "png", left, right)
        u.wait_for(lambda: len(self.rosout.find(NO_GRID)) > cleared, 10.0, "a new log line containing %r" % NO_GRID)
        level, message, values = u.wait_for(
            lambda: (lambda d: d if float(d[2]["input_block_grid"]) < 1.2 else None)(self.diagnostics()), 10.0,
            "the diagnostics without the grid")
        print("PNG: input_block_grid %s, %r" % (values["input_block_grid"], message))
        self.assertNotIn("block-coded", message)

    def test_3_bad_frames_are_dropped_with_the_reason(self):
        builtin = self.builtin()
        cases = [
            ("truncated JPEG", truncated_jpeg, compressed,
             "left compressed image (format 'bgr8; jpeg compressed bgr8') is a truncated JPEG"),
            ("corrupt JPEG", compressed, corrupt_jpeg,
             "right compressed image (format 'bgr8; jpeg compressed bgr8') is a corrupt JPEG"),
            ("16-bit PNG", png16, compressed,
             "is a 16-bit PNG: supported are 8-bit JPEG and PNG" if builtin else "left image has encoding 'mono16'"),
            ("no image", lambda a, s, f: with_data(compressed(a, s, f), b"not an image"), compressed,
             "is neither a JPEG nor a PNG"),
        ]
        for name, make_left, make_right, text in cases:
            bad = STAMPS.next()
            publish = (lambda: self.publish(bad, make_left(self.left, bad, u.LEFT_FRAME),
                                            make_right(self.right, bad, u.RIGHT_FRAME)))
            if builtin or name == "16-bit PNG":
                u.publish_until(publish, lambda: self.rosout.find(text), 15.0,
                                "%s: a log line containing %r" % (name, text))
            else:
                publish()  # the plugin drops what it cannot decode; it may decode a truncated JPEG's top
                rospy.sleep(0.5)
            self.good()  # the next good frame goes out
            if builtin:
                self.assertIsNone(self.disparity.with_stamp(bad), name + ": the bad frame was published")
        if builtin:
            # The same problem again and again: logged once per 5 s, counted every time.
            text = cases[0][3]
            logged = len(self.rosout.find(text))
            for _ in range(3):
                s = STAMPS.next()
                self.publish(s, truncated_jpeg(self.left, s, u.LEFT_FRAME), compressed(self.right, s, u.RIGHT_FRAME))
                rospy.sleep(0.1)
            self.good()
            self.assertEqual(len(self.rosout.find(text)), logged, "a repeated problem was logged again at once")
        self.assertTrue(rosgraph.Master("/test").lookupNode(MANAGER))
        got = []
        sub = rospy.Subscriber("/diagnostics", DiagnosticArray, lambda m: got.extend(
            {kv.key: kv.value for kv in s.values} for s in m.status if NODELET in s.name))
        try:
            diag = u.wait_for(lambda: got and got[-1], 10.0, "diagnostics of " + NODELET)
        finally:
            sub.unregister()
        self.assertGreaterEqual(int(diag["rejected"]), len(cases) + 3 if builtin else 1)
        self.assertEqual(int(diag["errors"]), 0)


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_compressed_input", TestCompressedInput)
