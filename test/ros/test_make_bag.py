#!/usr/bin/env python3
"""make_bag.test: bdis_make_bag refuses bad options and output paths with a
one-line message and a non-zero exit, before reading any image, and leaves
no bag behind: not for a bad --start, a bad name, an output path in a missing
folder or on a folder, nor when writing fails half-way."""
import importlib.machinery
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
import unittest
from unittest import mock

import cv2
import rosbag
import rostest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_rostest_util as u  # noqa: E402

FRAMES = 2
SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts", "bdis_make_bag")


class TestMakeBag(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="bdis_make_bag_")
        self.seq = os.path.join(self.tmp, "seq")
        os.makedirs(os.path.join(self.seq, "left"))
        os.makedirs(os.path.join(self.seq, "right"))
        for i in range(FRAMES):
            left, right = u.make_pair(seed=i)
            cv2.imwrite(os.path.join(self.seq, "left", "%06d.png" % i), left)
            cv2.imwrite(os.path.join(self.seq, "right", "%06d.png" % i), right)
        u.common.write_camera(os.path.join(self.seq, "camera.yaml"), u.W, u.H, u.FX, u.FX, u.CX, u.CY,
                              u.BASELINE)
        self.out_dir = os.path.join(self.tmp, "out")
        os.makedirs(self.out_dir)

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def run_tool(self, *args):
        return subprocess.run([u.common.find_program("bdis_make_bag"), self.seq] + list(args),
                              capture_output=True, text=True, timeout=60)

    def assert_refused(self, message, *args):
        out = self.run_tool(*args)
        self.assertEqual(out.returncode, 1, out.stderr)
        self.assertNotIn("Traceback", out.stderr)
        self.assertEqual(out.stderr.count("\n"), 1, out.stderr)  # one line
        self.assertIn(message, out.stderr)
        self.assertEqual(os.listdir(self.out_dir), [], "a bag or a partial file was left behind")

    def test_bad_start_is_refused_before_writing(self):
        bag = os.path.join(self.out_dir, "seq.bag")
        self.assert_refused("--start -10 gives stamps from -10 to -9.96667 s, outside the ROS time range "
                            "0 .. 4294967295 s", bag, "--start", "-10")
        self.assert_refused("--start 1e+12 gives stamps", bag, "--start", "1e12")
        self.assert_refused("--start must be a finite number", bag, "--start", "nan")
        self.assert_refused("--rate must be a finite number > 0, got inf", bag, "--rate", "inf")
        # The last of 3 x 2 frames at 1 Hz is 5 s after the start: just inside, and just outside.
        self.assert_refused("outside the ROS time range", bag, "--start", "4294967291", "--rate", "1",
                            "--loops", "3")
        out = self.run_tool(bag, "--start", "4294967290", "--rate", "1", "--loops", "3")
        self.assertEqual(out.returncode, 0, out.stderr)
        with rosbag.Bag(bag) as written:
            stamps = [t.to_sec() for _, _, t in written.read_messages(topics=["/stereo/left/image_rect"])]
        self.assertEqual(stamps, [4294967290.0 + i for i in range(6)])

    def test_bad_names_are_refused(self):
        bag = os.path.join(self.out_dir, "seq.bag")
        self.assert_refused("--ns 'bad ns!' is not a legal ROS namespace", bag, "--ns", "bad ns!")
        for ns in ("1stereo", "stereo//left", "~stereo"):
            self.assert_refused("--ns %r is not a legal ROS namespace" % ns, bag, "--ns", ns)
        self.assert_refused("--left-frame '/cam' is not a legal tf frame id", bag, "--left-frame", "/cam")
        self.assert_refused("--right-frame 'a b' is not a legal tf frame id", bag, "--right-frame", "a b")
        out = self.run_tool(bag, "--ns", "endoscope/stereo")
        self.assertEqual(out.returncode, 0, out.stderr)
        with rosbag.Bag(bag) as written:
            topics = sorted(written.get_type_and_topic_info().topics)
        self.assertIn("/endoscope/stereo/left/image_rect", topics)

    def test_bad_output_paths_are_refused(self):
        self.assert_refused("cannot write %s: directory %s does not exist"
                            % (os.path.join(self.out_dir, "missing", "seq.bag"),
                               os.path.join(self.out_dir, "missing")),
                            os.path.join(self.out_dir, "missing", "seq.bag"))
        # A folder as the output: refused, the folder untouched.
        folder = os.path.join(self.out_dir, "folder")
        os.makedirs(folder)
        out = self.run_tool(folder)
        self.assertEqual(out.returncode, 1, out.stderr)
        self.assertIn("cannot write %s: is a directory" % folder, out.stderr)
        self.assertNotIn("Traceback", out.stderr)
        self.assertEqual(os.listdir(self.out_dir), ["folder"])
        self.assertEqual(os.listdir(folder), [])

    def test_a_failure_while_writing_leaves_no_partial_bag(self):
        """Writing fails after some messages (as on a full disk): the partial
        file is removed and an existing bag of that name is kept as it was."""
        bag = os.path.join(self.out_dir, "seq.bag")
        with open(bag, "wb") as f:
            f.write(b"the previous bag")
        loader = importlib.machinery.SourceFileLoader("bdis_make_bag", SCRIPT)
        spec = importlib.util.spec_from_loader("bdis_make_bag", loader)
        tool = importlib.util.module_from_spec(spec)
        loader.exec_module(tool)
        real_write = rosbag.Bag.write
        calls = []

        def failing_write(bag_self, *args, **kwargs):
            calls.append(1)
            if len(calls) > 3:
                raise OSError(28, "No space left on device")
            return real_write(bag_self, *args, **kwargs)

        with mock.patch.object(rosbag.Bag, "write", failing_write), \
                mock.patch.object(sys, "argv", ["bdis_make_bag", self.seq, bag]), \
                mock.patch("sys.stderr", new_callable=lambda: _Capture()) as err:
            with self.assertRaises(SystemExit) as exit_info:
                tool.main()
        self.assertEqual(exit_info.exception.code, 1)
        self.assertIn("cannot write %s: OSError: [Errno 28] No space left on device" % bag, err.text)
        self.assertEqual(os.listdir(self.out_dir), ["seq.bag"])
        with open(bag, "rb") as f:
            self.assertEqual(f.read(), b"the previous bag")

    def test_a_written_bag_is_readable_by_others(self):
        bag = os.path.join(self.out_dir, "seq.bag")
        out = self.run_tool(bag, "--start", "0")
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertEqual(os.listdir(self.out_dir), ["seq.bag"])
        umask = os.umask(0)
        os.umask(umask)
        self.assertEqual(os.stat(bag).st_mode & 0o777, 0o666 & ~umask)

    def test_one_frame_for_both_cameras_writes_no_rig_transform(self):
        # stereo_image_proc wants one frame id for both cameras (scripts/bench_node.sh).
        import rosbag
        bag = os.path.join(self.out_dir, "one_frame.bag")
        out = self.run_tool(bag, "--right-frame", "stereo_left_optical")
        self.assertEqual(out.returncode, 0, out.stderr)
        with rosbag.Bag(bag) as b:
            topics = b.get_type_and_topic_info().topics
            self.assertNotIn("/tf_static", topics)
            self.assertEqual(topics["/stereo/right/camera_info"].message_count, FRAMES)
            frames = {m.header.frame_id for _, m, _ in b.read_messages(topics=["/stereo/right/camera_info"])}
        self.assertEqual(frames, {"stereo_left_optical"})


class _Capture:
    """A stderr stand-in that keeps what is written."""

    def __init__(self):
        self.text = ""

    def write(self, s):
        self.text += s

    def flush(self):
        pass


if __name__ == "__main__":
    rostest.rosrun("bdis_stereo", "test_make_bag", TestMakeBag)
