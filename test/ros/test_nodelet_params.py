#!/usr/bin/env python3
"""params.test: invalid values set with rosparam before the nodelet loads are
rejected one by one with a log line naming the parameter, the effective value
is written back, and the nodelet works with it; invalid values through
dynamic_reconfigure are rejected (NaN, inconsistent levels) or clamped to the
range, said so in the log, and frames keep coming; min_confidence set live
drops the less confident estimates, with or without a confidence subscriber."""
import math
import os
import signal
import subprocess
import sys
import unittest

import numpy as np
import rospy
import yaml
import rostest
from sensor_msgs.msg import Image
from stereo_msgs.msg import DisparityImage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402

MANAGER = "/manager"


STAMPS = u.StampSequence(500.0)


class LoadedNodelet(object):
    """bdis_stereo loaded into /manager as <ns>/bdis by nodelet's loader,
    unloaded (SIGINT to the loader) on close."""

    def __init__(self, ns):
        self.name = ns + "/bdis"
        self.loader = subprocess.Popen(
            ["rosrun", "nodelet", "nodelet", "load", "bdis_stereo/BdisStereoNodelet", MANAGER,
             "__name:=bdis", "__ns:=" + ns], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        # Loaded for good once the loader (node <ns>/bdis) holds its bond with
        # the manager: the load call has returned, so SIGINT unloads it.
        u.wait_for(lambda: self.name in u.common.publishers(MANAGER + "/bond"), 60.0,
                   "nodelet %s to load" % self.name)

    def close(self):
        self.loader.send_signal(signal.SIGINT)
        try:
            self.loader.wait(15)
        except subprocess.TimeoutExpired:
            self.loader.kill()
            self.loader.wait()
        u.wait_nodelet_unloaded(self.name)


class TestNodeletParams(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_nodelet_params")
        cls.rosout = u.RosoutWatcher(MANAGER)
        cls.left, cls.right = u.make_pair(seed=5)
        u.wait_for(lambda: any(t == MANAGER + "/load_nodelet" for t in _services()), 30.0, "the manager")
        rospy.sleep(1.0)  # the /rosout subscription reaches rosout

    def first_disparity(self, ns):
        """Publishes a good pair into `ns` until its disparity comes out."""
        inputs = u.StereoInput(ns)
        disp = u.Collector(ns + "/disparity", DisparityImage)
        try:
            inputs.wait_connected()
            stamp = STAMPS.next()
            return u.publish_until(lambda: inputs.publish_pair(stamp, self.left, self.right),
                                   lambda: disp.with_stamp(stamp), 20.0, ns + "/disparity")
        finally:
            disp.close()

    def check_disparity(self, msg):
        d = u.float_image(msg.image)[8:-8, u.DISPARITY + 16:-8]
        self.assertGreater((np.abs(d - u.DISPARITY) < 0.5).mean(), 0.9)

    def test_invalid_rosparams_are_rejected_one_by_one(self):
        ns = "/bad"
        bad = {
            "preset": "turbo",            # not a preset
            "patch_size": 1000,           # out of range
            "overlap": "lots",            # wrong type
            "iterations": 2.5,            # not an integer
            "sigma_r": float("nan"),
            "window_step": float("inf"),
            "coarsest_level": 1, "finest_level": 3,  # each valid, together not
            "queue_size": 0,
            "max_image_pixels": 10,
            "tf_timeout": -1.0,
        }
        for k, v in bad.items():
            rospy.set_param(ns + "/bdis/" + k, v)
        node = LoadedNodelet(ns)
        try:
            # The core's binder, as for parameter files and bdis_match --set; each
            # message names the source, then the replacement.
            for text in ("parameter server /bad/bdis: parameter preset = 'turbo' is unknown: expected one of "
                         "fast, balanced, accurate; using 'balanced'",
                         "parameter patch_size = 1000 is out of range [4, 32]: patch side p, px at each level; "
                         "smaller where finest_level -1 rounds the level up (6 at 1920 px); using 8",
                         "parameter overlap = 'lots' must be a number",
                         "parameter iterations = 2.5 must be a whole number",
                         "parameter sigma_r = nan is not a finite number",
                         "parameter window_step = inf is not a finite number",
                         "coarser than coarsest_level", "using the balanced preset's pyramid levels",
                         "parameter queue_size = 0 is out of range [1, 1000]",
                         "parameter max_image_pixels = 10 is out of range [1024, 2147483647]",
                         "parameter tf_timeout = -1.0 is out of range [0, 1]"):
                self.rosout.wait_text(text)
            # The effective values are written back.
            p = lambda k: rospy.get_param(ns + "/bdis/" + k)  # noqa: E731
            self.assertEqual(p("preset"), "balanced")
            # The balanced preset's values (config/default.yaml holds them; test_params keeps it so).
            with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config",
                                   "default.yaml")) as f:
                balanced = yaml.safe_load(f)
            for k in ("patch_size", "iterations", "coarsest_level", "finest_level"):
                self.assertEqual(p(k), balanced[k], k)
            for k in ("overlap", "sigma_r", "window_step"):
                self.assertAlmostEqual(p(k), balanced[k], places=5, msg=k)
            self.assertEqual((p("queue_size"), p("tf_timeout")), (5, 0.01))
            # And it works with them.
            self.check_disparity(self.first_disparity(ns))
        finally:
            node.close()

    def test_invalid_dynamic_reconfigure_values(self):
        import dynamic_reconfigure.client
        ns = "/dr"
        node = LoadedNodelet(ns)
        client = dynamic_reconfigure.client.Client(ns + "/bdis", timeout=10)
        try:
            # NaN passes dynamic_reconfigure's range clamp; the nodelet rejects it.
            cfg = client.update_configuration({"sigma_r": float("nan")})
            self.assertAlmostEqual(cfg["sigma_r"], 0.5, places=5)
            self.rosout.wait_text("dynamic_reconfigure: rejected (parameter sigma_r = nan is not a finite number")
            # Outside the range: clamped to its end, and said so.
            cfg = client.update_configuration({"patch_size": 1000})
            self.assertEqual(cfg["patch_size"], 32)
            self.rosout.wait_text("dynamic_reconfigure: patch_size = 32, the upper end of its range [4, 32]")
            cfg = client.update_configuration({"overlap": -3.0})
            self.assertEqual(cfg["overlap"], 0.0)
            self.rosout.wait_text("dynamic_reconfigure: overlap = 0, the lower end of its range")
            cfg = client.update_configuration({"sigma_s": 1e9})
            self.assertEqual(cfg["sigma_s"], 100.0)
            self.rosout.wait_text("dynamic_reconfigure: sigma_s = 100, the upper end")
            # Each valid, together not: rejected, previous values kept.
            cfg = client.update_configuration({"coarsest_level": 1, "finest_level": 3})
            self.assertEqual((cfg["coarsest_level"], cfg["finest_level"]), (5, -1))
            # An unknown preset: kept.
            cfg = client.update_configuration({"preset": "turbo"})
            self.assertEqual(cfg["preset"], "balanced")
            self.rosout.wait_text("dynamic_reconfigure: parameter preset = 'turbo' is unknown: expected one of "
                                  "fast, balanced, accurate; keeping preset balanced")
            # Frames keep coming, and a valid update still takes effect.
            self.check_disparity(self.first_disparity(ns))
            cfg = client.update_configuration({"patch_size": 8, "overlap": 0.6, "sigma_s": 4.0})
            self.assertEqual(cfg["patch_size"], 8)
            self.check_disparity(self.first_disparity(ns))
            self.assertFalse([m for m in self.rosout.find("the upper end") if "patch_size = 8" in m])
        finally:
            client.close()
            node.close()

    def test_min_confidence_drops_the_less_confident_estimates(self):
        import dynamic_reconfigure.client
        ns = "/conf"
        node = LoadedNodelet(ns)
        client = dynamic_reconfigure.client.Client(ns + "/bdis", timeout=10)
        confidence = u.Collector(ns + "/confidence", Image)
        try:
            def estimates(msg):
                return u.float_image(msg.image) >= 0.0

            # Unfiltered, with a confidence subscriber: its median over the estimates.
            before = self.first_disparity(ns)
            c = u.float_image(confidence.wait_stamp(before.header.stamp))
            kept = estimates(before)
            self.assertGreater(kept.mean(), 0.5)
            threshold = float(np.median(c[kept]))
            self.assertGreater(threshold, 0.0)
            # The share that reaches it: about half, more where estimates tie
            # at the median (the calibrated confidence's steps near 1).
            reaching = (c[kept] >= threshold).mean() * kept.mean()
            cfg = client.update_configuration({"min_confidence": threshold})
            self.assertAlmostEqual(cfg["min_confidence"], threshold, places=5)
            # The same pair with the confidence subscribed: every estimate left
            # reaches the threshold, every pixel without one has confidence 0.
            after = self.first_disparity(ns)
            c = u.float_image(confidence.wait_stamp(after.header.stamp))
            left = estimates(after)
            self.assertTrue((c[left] >= threshold).all())
            self.assertTrue((c[~left] == 0.0).all())
            self.assertAlmostEqual(left.mean(), reaching, delta=0.02 * kept.mean())
            # And without a confidence subscriber: the same estimates.
            confidence.close()
            confidence = None
            u.wait_for(lambda: not u.common.subscribers(ns + "/confidence"), 10.0, "the confidence unsubscribed")
            rospy.sleep(0.5)  # the nodelet's publisher sees the link go
            unsubscribed = estimates(self.first_disparity(ns))
            self.assertTrue((unsubscribed == left).all())
        finally:
            if confidence:
                confidence.close()
            client.close()
            node.close()


def _services():
    import rosservice
    try:
        return rosservice.get_service_list()
    except Exception:  # the master is still coming up
        return []


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_nodelet_params", TestNodeletParams)
