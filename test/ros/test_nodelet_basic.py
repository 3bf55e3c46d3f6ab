#!/usr/bin/env python3
"""The nodelet in a manager (basic.test): lazy subscription, outputs against the
exact truth of a synthetic pair, bad inputs, dynamic_reconfigure, diagnostics.
Nodelet /stereo/bdis (organised cloud, exact sync) and /stereo_dense/bdis
(organized_cloud: false) read the same /stereo inputs.
node.test runs the same cases against the standalone bdis_stereo_node, which
logs under its own name: `--log-node /stereo/bdis`."""
import os
import sys
import unittest

import numpy as np
import rosgraph
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import CameraInfo, Image, PointCloud2, PointField
from stereo_msgs.msg import DisparityImage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402

NODELET = "/stereo/bdis"
# The process whose /rosout messages carry the nodelet's log lines.
MANAGER = (sys.argv[sys.argv.index("--log-node") + 1] if "--log-node" in sys.argv
           else "/stereo/manager")


STAMPS = u.StampSequence(100.0)


class TestNodeletBasic(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_nodelet_basic")
        cls.inputs = u.StereoInput("/stereo")
        cls.rosout = u.RosoutWatcher(MANAGER)  # nodelets log under their manager's name
        cls.left, cls.right = u.make_pair(seed=1)
        u.wait_nodelet_loaded(NODELET)

    def good_frame(self, stamp=None):
        stamp = stamp or STAMPS.next()
        self.inputs.publish_pair(stamp, self.left, self.right)
        return stamp

    def processed(self, collector, timeout=20.0, **pair_args):
        """Publishes a good pair (repeatedly, same stamp) until `collector` has
        its output; returns (stamp, message)."""
        stamp = STAMPS.next()
        msg = u.publish_until(lambda: self.inputs.publish_pair(stamp, self.left, self.right, **pair_args),
                              lambda: collector.with_stamp(stamp), timeout,
                              "%s with stamp %.3f" % (collector.sub.name, stamp.to_sec()))
        return stamp, msg

    def diagnostics(self, timeout=10.0):
        """The next diagnostics status of /stereo/bdis, as a dict."""
        got = []

        def cb(msg):
            for s in msg.status:
                if NODELET in s.name:
                    got.append({kv.key: kv.value for kv in s.values})
        sub = rospy.Subscriber("/diagnostics", DiagnosticArray, cb)
        try:
            return u.wait_for(lambda: got and got[-1], timeout, "diagnostics of " + NODELET)
        finally:
            sub.unregister()

    # ---- lazy -------------------------------------------------------------
    def test_01_lazy_no_subscriber_no_processing(self):
        self.assertEqual(self.inputs.connections(), [0, 0, 0, 0],
                         "the nodelet subscribed to its inputs without an output subscriber")
        for _ in range(3):
            self.good_frame()
        diag = self.diagnostics()  # published after the frames: none was received
        self.assertEqual(diag["subscribed"], "False")
        self.assertEqual(diag["frames_in"], "0")
        self.assertEqual(diag["left_images"], "0")
        # An output subscriber makes it subscribe; its departure makes it leave.
        conf = u.Collector("/stereo/confidence", Image)
        self.inputs.wait_connected()
        _, msg = self.processed(conf)
        self.assertEqual(msg.encoding, "32FC1")
        conf.close()
        u.wait_for(lambda: self.inputs.connections() == [0, 0, 0, 0], 10.0,
                   "the nodelet to unsubscribe after the last output subscriber left")

    # ---- outputs against the truth ------------------------------------------
    def check_outputs(self, cx_right, expected_d):
        disp = u.Collector("/stereo/disparity", DisparityImage)
        depth = u.Collector("/stereo/depth/image_rect", Image)
        depth_info = u.Collector("/stereo/depth/camera_info", CameraInfo)
        conf = u.Collector("/stereo/confidence", Image)
        cloud = u.Collector("/stereo/points2", PointCloud2)
        dense = u.Collector("/stereo_dense/points2", PointCloud2)
        try:
            self.inputs.wait_connected()
            u.wait_for(lambda: all(c.sub.get_num_connections() > 0
                                   for c in (disp, depth, depth_info, conf, cloud, dense)),
                       10.0, "output connections")
            # Republish until every output has the frame: the two nodes (or
            # processes, in node.test) subscribe to the inputs independently.
            stamp = STAMPS.next()
            outputs = (disp, depth, depth_info, conf, cloud, dense)
            u.publish_until(lambda: self.inputs.publish_pair(stamp, self.left, self.right, cx_right=cx_right),
                            lambda: all(c.with_stamp(stamp) for c in outputs), 20.0,
                            "every output with stamp %.3f" % stamp.to_sec())
            d_msg = disp.wait_stamp(stamp)
            z_msg = depth.wait_stamp(stamp)
            zi_msg = depth_info.wait_stamp(stamp)
            c_msg = conf.wait_stamp(stamp)
            p_msg = cloud.wait_stamp(stamp)
            dense_msg = dense.wait_stamp(stamp)
        finally:
            for c in (disp, depth, depth_info, conf, cloud, dense):
                c.close()

        for m in (d_msg, d_msg.image, z_msg, zi_msg, c_msg, p_msg, dense_msg):
            self.assertEqual(m.header.stamp, stamp)
            self.assertEqual(m.header.frame_id, u.LEFT_FRAME)
        # Disparity: stereo_msgs convention, Z = f * T / d.
        self.assertAlmostEqual(d_msg.f, u.FX, places=3)
        self.assertAlmostEqual(d_msg.T, u.BASELINE, places=6)
        self.assertEqual(d_msg.min_disparity, 0.0)
        self.assertGreaterEqual(d_msg.max_disparity, expected_d)
        d = u.float_image(d_msg.image)
        self.assertEqual(d.shape, (u.H, u.W))
        valid = d >= d_msg.min_disparity
        inner = (slice(8, u.H - 8), slice(u.DISPARITY + 16, u.W - 8))  # textured, matchable
        self.assertGreater(valid[inner].mean(), 0.95, "density on the textured area")
        err = np.abs(d[inner][valid[inner]] - expected_d)
        self.assertLess(np.median(err), 0.1)
        self.assertGreater((err < 0.5).mean(), 0.97, "share within 0.5 px of the truth")
        self.assertLess(valid[:, :u.DISPARITY - 2].mean(), 0.05,
                        "estimates where the point is outside the right image")
        vw = d_msg.valid_window
        ys, xs = np.nonzero(valid)
        self.assertEqual((vw.x_offset, vw.y_offset, vw.width, vw.height),
                         (xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1))
        # Depth: REP 118, fx * B / d, NaN exactly where there is no disparity.
        z = u.float_image(z_msg)
        np.testing.assert_array_equal(np.isnan(z), ~valid)
        np.testing.assert_allclose(z[valid], u.FX * u.BASELINE / d[valid], rtol=1e-5)
        self.assertAlmostEqual(float(np.median(z[inner])), u.FX * u.BASELINE / expected_d, places=3)
        self.assertEqual(list(zi_msg.P), list(u.info_msg(stamp).P))
        # Confidence in [0, 1].
        c = u.float_image(c_msg)
        self.assertTrue(np.all((c >= 0) & (c <= 1)))
        self.assertGreater(float(np.median(c[inner])), 0.1)
        # Organised cloud: x, y, z, rgb float32; pinhole model and depth.
        self.assertEqual([(f.name, f.offset, f.datatype, f.count) for f in p_msg.fields],
                         [("x", 0, PointField.FLOAT32, 1), ("y", 4, PointField.FLOAT32, 1),
                          ("z", 8, PointField.FLOAT32, 1), ("rgb", 12, PointField.FLOAT32, 1)])
        self.assertEqual((p_msg.height, p_msg.width, p_msg.is_dense), (u.H, u.W, False))
        pts = u.cloud_array(p_msg)
        np.testing.assert_array_equal(np.isnan(pts["z"]), ~valid)
        vv, uu = np.nonzero(valid)
        zz = z[valid]
        np.testing.assert_allclose(pts["z"][valid], zz, rtol=1e-6)
        np.testing.assert_allclose(pts["x"][valid], (uu - u.CX) * zz / u.FX, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(pts["y"][valid], (vv - u.CY) * zz / u.FX, rtol=1e-5, atol=1e-6)
        rgb = pts["rgb"].copy().view(np.uint32)
        b, g, r = self.left[..., 0], self.left[..., 1], self.left[..., 2]
        np.testing.assert_array_equal(rgb, (r.astype(np.uint32) << 16) | (g.astype(np.uint32) << 8) | b)
        # Dense cloud: the same valid points only.
        self.assertEqual((dense_msg.height, dense_msg.width, dense_msg.is_dense), (1, int(valid.sum()), True))
        dpts = u.cloud_array(dense_msg)[0]
        np.testing.assert_allclose(dpts["z"], pts["z"][valid], rtol=1e-6)

    def test_02_outputs_match_the_truth(self):
        self.check_outputs(cx_right=u.CX, expected_d=u.DISPARITY)

    def test_03_principal_point_offset_is_corrected(self):
        # Right principal point 2 px left: infinity is at raw d = 2, so the
        # published disparity is 8 - 2 = 6 and Z = f * T / 6.
        self.check_outputs(cx_right=u.CX - 2.0, expected_d=u.DISPARITY - 2)

    # ---- bad inputs -----------------------------------------------------------
    def test_04_bad_inputs_are_reported_and_dropped(self):
        disp = u.Collector("/stereo/disparity", DisparityImage)
        try:
            self.inputs.wait_connected()
            L, R = self.left, self.right
            tx = -u.FX * u.BASELINE
            cases = [
                ("right image smaller",
                 lambda s: (u.image_msg(L, s), u.image_msg(R[:100], s, u.RIGHT_FRAME),
                            u.info_msg(s), u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "left image is 192x144 but right image is 192x100"),
                ("right P[3] = 0",
                 lambda s: (u.image_msg(L, s), u.image_msg(R, s, u.RIGHT_FRAME),
                            u.info_msg(s), u.info_msg(s, u.RIGHT_FRAME, tx=0.0)),
                 "right camera_info P[3] is 0: is the pair rectified as a stereo pair?"),
                ("swapped", lambda s: (u.image_msg(L, s), u.image_msg(R, s, u.RIGHT_FRAME),
                                       u.info_msg(s), u.info_msg(s, u.RIGHT_FRAME, tx=-tx)),
                 "are the cameras swapped?"),
                # Images swapped, camera_infos right: only the images tell.
                ("swapped images", lambda s: (u.image_msg(R, s), u.image_msg(L, s, u.RIGHT_FRAME),
                                              u.info_msg(s), u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "distinct matches lie at negative disparity"),
                ("16-bit", lambda s: (u.image_msg(L[..., 0].astype(np.uint16), s, encoding="mono16"),
                                      u.image_msg(R, s, u.RIGHT_FRAME), u.info_msg(s),
                                      u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "left image has encoding 'mono16'"),
                ("empty", lambda s: (u.image_msg(L, s), u.image_msg(np.zeros((0, 0), np.uint8), s, u.RIGHT_FRAME),
                                     u.info_msg(s), u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "right image is empty"),
                ("NaN in P", lambda s: (u.image_msg(L, s), u.image_msg(R, s, u.RIGHT_FRAME),
                                        u.info_msg(s, fx=float("nan")), u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "left camera_info P[0] is nan"),
                ("all-zero camera_info", lambda s: (u.image_msg(L, s), u.image_msg(R, s, u.RIGHT_FRAME),
                                                    CameraInfo(header=u.info_msg(s).header),
                                                    u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "is the camera calibrated"),
                ("inf in P", lambda s: (u.image_msg(L, s), u.image_msg(R, s, u.RIGHT_FRAME),
                                        u.info_msg(s), u.info_msg(s, u.RIGHT_FRAME, tx=float("inf"))),
                 "right camera_info P[3] is inf"),
                ("yuv422", lambda s: (u.image_msg(L[..., :2].copy(), s, encoding="yuv422"),
                                      u.image_msg(R, s, u.RIGHT_FRAME), u.info_msg(s),
                                      u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "left image has encoding 'yuv422'"),
                ("1xN", lambda s: (u.image_msg(L[:1], s), u.image_msg(R[:1], s, u.RIGHT_FRAME),
                                   u.info_msg(s, h=1), u.info_msg(s, u.RIGHT_FRAME, tx=tx, h=1)),
                 "left image is 192x1: each side must be at least 32 px"),
                # Above max_image_pixels (default 4096 x 4096): refused before
                # anything is allocated for it.
                ("oversize", lambda s: (u.image_msg(np.zeros((4100, 4100), np.uint8), s),
                                        u.image_msg(R, s, u.RIGHT_FRAME), u.info_msg(s),
                                        u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "left image is 4100x4100, more than max_image_pixels = 16777216"),
                ("camera_info size", lambda s: (u.image_msg(L, s), u.image_msg(R, s, u.RIGHT_FRAME),
                                                u.info_msg(s, w=640, h=480),
                                                u.info_msg(s, u.RIGHT_FRAME, tx=tx)),
                 "left camera_info is for 640x480"),
            ]
            for name, make, text in cases:
                if name == "swapped images":
                    # The image check runs on the first frame and then once a
                    # second (a swap is a setup error, there from the start).
                    rospy.sleep(1.2)
                bad = STAMPS.next()
                u.publish_until(lambda: self.inputs.publish(*make(bad)), lambda: self.rosout.find(text),
                                15.0, "a log line containing %r" % text)
                self.processed(disp)  # the manager is alive and the next good frame goes out
                self.assertIsNone(disp.with_stamp(bad), name + ": the bad frame was published")
            master = rosgraph.Master("/test")
            self.assertTrue(master.lookupNode(MANAGER))
            diag = self.diagnostics()
            self.assertGreaterEqual(int(diag["rejected"]), len(cases))
        finally:
            disp.close()

    def test_05_differing_stamps_warn_about_approximate_sync(self):
        disp = u.Collector("/stereo/disparity", DisparityImage)
        try:
            self.inputs.wait_connected()
            sent = []
            for _ in range(6):  # 6 x 0.25 s > sync_warn_timeout = 1 s (basic.test)
                s = STAMPS.next()
                sent.append(s)
                self.inputs.publish_pair(s, self.left, self.right, right_stamp=s + rospy.Duration(0.003))
                rospy.sleep(0.25)  # paces the input like a camera; not a synchronisation
            self.rosout.wait_text("try approximate_sync:=true")
            self.assertEqual([s for s in sent if disp.with_stamp(s)], [])
        finally:
            disp.close()

    # ---- dynamic_reconfigure ------------------------------------------------------
    def test_06_dynamic_reconfigure_takes_effect(self):
        import dynamic_reconfigure.client
        client = dynamic_reconfigure.client.Client(NODELET, timeout=10)
        var = u.Collector("/stereo/variance", Image)
        disp = u.Collector("/stereo/disparity", DisparityImage)
        try:
            self.inputs.wait_connected()
            _, msg = self.processed(disp)
            before = u.float_image(msg.image)
            self.assertGreater((before >= 0).mean(), 0.8)
            self.assertEqual(var.count(), 0, "variance published while compute_variance is off")
            cfg = client.update_configuration({"compute_variance": True})
            self.assertTrue(cfg["compute_variance"])
            stamp, msg = self.processed(var)
            v = u.float_image(msg)
            ok = u.float_image(disp.wait_stamp(stamp).image) >= 0
            self.assertTrue(np.all(np.isfinite(v[ok])) and np.all(v[ok] >= 0))
            # A flat likelihood (sigma_r at its maximum, no contrast share): no
            # patch is confident, so no pixel keeps a disparity.
            client.update_configuration({"sigma_r": 255.0, "contrast_share": 0.0})
            _, msg = self.processed(disp)
            self.assertLess((u.float_image(msg.image) >= 0).mean(), 0.05,
                            "sigma_r = 255 left the density unchanged")
            # Invalid combination: rejected, previous values kept.
            cfg = client.update_configuration({"coarsest_level": 1, "finest_level": 3})
            self.assertEqual((cfg["coarsest_level"], cfg["finest_level"]), (5, -1))
            self.rosout.wait_text("dynamic_reconfigure: rejected")
            # A preset sets every field.
            cfg = client.update_configuration({"preset": "fast"})
            self.assertAlmostEqual(cfg["overlap"], 0.4, places=5)
            self.assertAlmostEqual(cfg["confidence_floor"], 0.0175, places=5)
            self.assertFalse(cfg["compute_variance"])
            self.assertAlmostEqual(cfg["sigma_r"], 0.5, places=5)
            _, msg = self.processed(disp)
            self.assertGreater((u.float_image(msg.image) >= 0).mean(), 0.8)
            client.update_configuration({"preset": "balanced"})
        finally:
            var.close()
            disp.close()
            client.close()

    def test_07_diagnostics_count_frames(self):
        disp = u.Collector("/stereo/disparity", DisparityImage)
        try:
            self.inputs.wait_connected()
            self.processed(disp)
            diag = u.wait_for(lambda: (lambda d: d if int(d["frames_out"]) > 0 else None)(self.diagnostics()),
                              10.0, "frames_out > 0 in diagnostics")
            for key in ("frames_in", "frames_out", "dropped_busy", "rejected", "input_rate_hz",
                        "output_rate_hz", "processing_ms_mean", "processing_ms_max", "latency_ms_p50"):
                self.assertIn(key, diag)
            self.assertGreater(float(diag["processing_ms_max"]) + float(diag["latency_ms_p50"]), 0.0)
        finally:
            disp.close()

    # ---- time jumps back (last: it moves the stamps back) -------------------------
    def test_08_time_jump_back_resets_the_synchroniser(self):
        """A bag that loops, after a camera that lost frames: the exact
        synchroniser still holds incomplete sets (left images whose right
        partner never came) stamped after the new frames. Kept, they are the
        newest entries, and each new set would be evicted before completing."""
        disp = u.Collector("/stereo/disparity", DisparityImage)
        try:
            self.inputs.wait_connected()
            before, _ = self.processed(disp)
            for _ in range(8):  # more than queue_size (5): left only
                s = STAMPS.next()
                self.inputs.pubs[0].publish(u.image_msg(self.left, s))
                self.inputs.pubs[2].publish(u.info_msg(s))
            rospy.sleep(0.5)
            STAMPS.t = before.to_sec() - 50.0  # the bag starts over
            after, msg = self.processed(disp)
            self.assertLess(after, before)
            d = u.float_image(msg.image)[8:-8, u.DISPARITY + 16:-8]
            self.assertGreater((np.abs(d - u.DISPARITY) < 0.5).mean(), 0.95)
            self.rosout.wait_text("stamp jumped back")
            self.assertTrue(self.rosout.find("synchroniser reset"))
            diag = u.wait_for(lambda: (lambda d: d if int(d["time_jumps"]) > 0 else None)(self.diagnostics()),
                              10.0, "time_jumps > 0 in diagnostics")
            self.assertEqual(int(diag["errors"]), 0)
            # And on from there.
            self.processed(disp)
        finally:
            disp.close()


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_nodelet_basic", TestNodeletBasic)
