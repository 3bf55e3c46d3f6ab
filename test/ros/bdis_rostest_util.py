"""Helpers of the bdis_stereo rostests: exact synthetic stereo pairs, message
builders, and subscribers that wait for a condition with a timeout. What the
demo and the bag tool share with them is in scripts/bdis_common.py."""
import os
import sys
import threading
import time

import cv2
import numpy as np
import rospy
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import bdis_common as common  # noqa: E402

# Camera of the synthetic pairs: Z = FX * BASELINE / d.
W, H = 192, 144
FX = 200.0
CX, CY = 96.0, 72.0
BASELINE = 0.1
DISPARITY = 8
LEFT_FRAME = "cam_left_optical"
RIGHT_FRAME = "cam_right_optical"


def make_pair(seed=1, colour=True, d=DISPARITY, w=W, h=H):
    """Random smooth texture; right(x) = left(x + d), so the left disparity is
    exactly d wherever x >= d (left of that the point is outside the right image)."""
    rng = np.random.default_rng(seed)
    tex = rng.integers(0, 256, (h, w + d)).astype(np.float32)
    tex = cv2.GaussianBlur(tex, (0, 0), 1.2)
    tex = cv2.normalize(tex, None, 20, 235, cv2.NORM_MINMAX).astype(np.uint8)
    left, right = tex[:, :w].copy(), tex[:, d:d + w].copy()
    if colour:
        # A colour that differs per channel, so rgb in the cloud is checkable.
        left = np.dstack([left, 255 - left, np.full_like(left, 77)])
        right = np.dstack([right, 255 - right, np.full_like(right, 77)])
    return left, right


def image_msg(arr, stamp, frame_id=LEFT_FRAME, encoding=None):
    return common.image_msg(arr, frame_id, stamp, encoding)


def info_msg(stamp, frame_id=LEFT_FRAME, tx=0.0, cx=CX, w=W, h=H, fx=FX):
    return common.camera_info_msg([fx, 0, cx, tx, 0, fx, CY, 0, 0, 0, 1, 0], w, h, frame_id, stamp)


def wait_for(condition, timeout, what):
    """Polls `condition` until true and returns its value; raises an
    AssertionError naming `what` on timeout."""
    return common.wait_for(condition, timeout, what, period=0.02)


def publish_until(publish, condition, timeout, what, period=0.5):
    """Publishes (again every `period` s) until `condition` holds: robust against
    a subscription that is still being set up when the first copy goes out."""
    next_publish = [0.0]

    def published_and_holds():
        if time.monotonic() >= next_publish[0]:
            publish()
            next_publish[0] = time.monotonic() + period
        return condition()
    return wait_for(published_and_holds, timeout, what)


def wait_nodelet_loaded(name, timeout=30.0):
    wait_for(lambda: common.nodelet_loaded(name), timeout, "nodelet %s to load" % name)


def wait_nodelet_unloaded(name, timeout=30.0):
    wait_for(lambda: not common.nodelet_loaded(name), timeout, "nodelet %s to unload" % name)


class StampSequence(object):
    """Stamps 0.1 s apart, increasing from `start` (set `t` to jump)."""

    def __init__(self, start):
        self.t = start

    def next(self):
        self.t += 0.1
        return rospy.Time.from_sec(self.t)


class Collector(object):
    """Keeps every message of a topic."""

    def __init__(self, topic, msg_type):
        self.lock = threading.Lock()
        self.msgs = []
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=20)

    def _cb(self, msg):
        with self.lock:
            self.msgs.append(msg)

    def with_stamp(self, stamp):
        with self.lock:
            for m in self.msgs:
                if m.header.stamp == stamp:
                    return m
        return None

    def wait_stamp(self, stamp, timeout=20.0):
        return wait_for(lambda: self.with_stamp(stamp), timeout,
                        "%s with stamp %.3f" % (self.sub.name, stamp.to_sec()))

    def count(self):
        with self.lock:
            return len(self.msgs)

    def close(self):
        self.sub.unregister()


class RosoutWatcher(object):
    """Collects /rosout messages of one node (all nodes if name is None)."""

    def __init__(self, node=None):
        self.node = node
        self.lock = threading.Lock()
        self.lines = []
        self.sub = rospy.Subscriber("/rosout", Log, self._cb, queue_size=100)

    def _cb(self, msg):
        if self.node is None or msg.name == self.node:
            with self.lock:
                self.lines.append((msg.level, msg.msg))

    def find(self, text):
        with self.lock:
            return [m for _, m in self.lines if text in m]

    def wait_text(self, text, timeout=15.0):
        return wait_for(lambda: self.find(text), timeout, "a log line containing %r" % text)


class StereoInput(object):
    """The four input topics of the nodelet in namespace `ns`."""

    def __init__(self, ns):
        self.pubs = [rospy.Publisher(ns + t, m, queue_size=10) for t, m in (
            ("/left/image_rect", Image), ("/right/image_rect", Image),
            ("/left/camera_info", CameraInfo), ("/right/camera_info", CameraInfo))]

    def connections(self):
        return [p.get_num_connections() for p in self.pubs]

    def wait_connected(self, timeout=15.0):
        wait_for(lambda: all(c > 0 for c in self.connections()), timeout,
                 "the nodelet to subscribe to all four inputs")

    def publish(self, left, right, left_info, right_info):
        for p, m in zip(self.pubs, (left, right, left_info, right_info)):
            p.publish(m)

    def publish_pair(self, stamp, left_arr, right_arr, right_tx=-FX * BASELINE, cx_right=CX,
                     right_stamp=None):
        rs = right_stamp or stamp
        self.publish(image_msg(left_arr, stamp, LEFT_FRAME), image_msg(right_arr, rs, RIGHT_FRAME),
                     info_msg(stamp, LEFT_FRAME), info_msg(rs, RIGHT_FRAME, tx=right_tx, cx=cx_right))


def float_image(msg):
    assert msg.encoding == "32FC1", msg.encoding
    return common.image_array(msg)


cloud_array = common.cloud_array  # structured numpy array of a PointCloud2 with float32 x, y, z [, rgb]
