"""What the package's Python programs and tests share, written once: a free
port, the package's programs and embedded sample, camera.yaml, sensor_msgs
to and from numpy, waiting for a condition, what the ROS master knows, and
stopping a process group, montage panels. Installed beside bdis_demo and bdis_make_bag, which import it by
path, as do the tests (test/demo, test/ros); the shell scripts reach it through
scripts/common.sh, which runs it as a command:

    bdis_common.py free-port                 a TCP port free on loopback now
    bdis_common.py sample-dir                the embedded sample's folder
    bdis_common.py wait-master [--timeout S]
    bdis_common.py wait-nodelet NAME [--unloaded] [--timeout S]

A command that fails prints why on stderr and exits 1.
ROS modules are imported where they are used: the commands start fast."""
import argparse
import os
import signal
import socket
import subprocess
import sys
import time

PACKAGE = "bdis_stereo"


class Failure(Exception):
    """A failure whose message is for the user: printed without a traceback."""


class WaitError(Failure, AssertionError):
    """A condition that did not come true in time; an AssertionError too, so a
    unittest reports it as a failed check."""


# ---------------------------------------------------------------- processes
def free_port():
    """A TCP port free on loopback now (for a master of our own)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def log_tail(path, lines=25):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-lines:])
    except OSError:
        return ""


def wait_for(condition, timeout, what, period=0.05, watch=()):
    """Polls `condition` until it returns a true value, and returns that value.
    Raises WaitError naming `what` after `timeout` s, or as soon as a process of
    `watch` ((name, Popen, log path), ...) has exited, with the end of its log."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        for name, proc, log_path in watch:
            if proc.poll() is not None:
                raise WaitError("%s exited (code %s) while waiting for %s; its log:\n%s"
                                % (name, proc.returncode, what, log_tail(log_path)))
        if time.monotonic() >= deadline:
            raise WaitError("timed out after %.0f s waiting for %s" % (timeout, what))
        time.sleep(period)


def stop_process_group(proc, timeout=15.0):
    """SIGINT to the process group of `proc` (roslaunch and roscore stop their
    nodes on it), SIGKILL if it is not gone after `timeout` s."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    except ProcessLookupError:
        pass


# ---------------------------------------------------------------- the package
def find_program(name):
    """Path of one of the package's programs (bdis_eval, bdis_make_bag, ...)."""
    import roslib.packages
    found = roslib.packages.find_node(PACKAGE, name)
    if not found:
        raise Failure("%s is not built: build the package and source the workspace's "
                      "devel/setup.bash" % name)
    return found[0]


def sample_dir():
    """The embedded sample (share/bdis_stereo/sample), rendered at build time."""
    from catkin.find_in_workspaces import find_in_workspaces
    found = find_in_workspaces(search_dirs=["share"], project=PACKAGE, path="sample",
                               first_match_only=True)
    if not found or not os.path.isfile(os.path.join(found[0], "camera.yaml")):
        raise Failure("the embedded sample is not built (share/bdis_stereo/sample): build the "
                      "package (scripts/demo.sh does) or pass --data/--bag")
    return found[0]


# ---------------------------------------------------------------- camera.yaml
def load_camera(path):
    """camera.yaml of a sequence folder: fx, fy, cx, cy, baseline, image_width,
    image_height [, left_P, right_P: the 12 entries of the rectified P].
    Returns (the values, left P, right P); P is made from fx, fy, cx, cy and
    baseline where the file gives none. Raises Failure naming what is wrong."""
    import yaml
    try:
        with open(path) as f:
            cam = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as exc:
        raise Failure("cannot read %s: %s" % (path, exc))
    if not isinstance(cam, dict):
        raise Failure("%s is not a map of calibration values" % path)
    for key in ("fx", "fy", "cx", "cy", "baseline"):
        if not isinstance(cam.get(key), (int, float)):
            raise Failure("%s: '%s' is missing or not a number" % (path, key))
    if cam["fx"] <= 0 or cam["fy"] <= 0:
        raise Failure("%s: fx and fy must be > 0" % path)
    if cam["baseline"] <= 0:
        raise Failure("%s: baseline must be > 0 (left camera is the reference)" % path)
    fx, fy, cx, cy, b = (float(cam[k]) for k in ("fx", "fy", "cx", "cy", "baseline"))
    left_p = cam.get("left_P") or [fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0]
    right_p = cam.get("right_P") or [fx, 0, cx, -fx * b, 0, fy, cy, 0, 0, 0, 1, 0]
    for name, p in (("left_P", left_p), ("right_P", right_p)):
        if len(p) != 12:
            raise Failure("%s: %s must have 12 entries" % (path, name))
    if not right_p[3] < 0:
        raise Failure("%s: right_P[3] = %s must be -fx * baseline < 0" % (path, right_p[3]))
    return cam, [float(v) for v in left_p], [float(v) for v in right_p]


def write_camera(path, width, height, fx, fy, cx, cy, baseline):
    """camera.yaml as load_camera reads it (no left_P / right_P)."""
    with open(path, "w") as f:
        f.write("image_width: %d\nimage_height: %d\nfx: %r\nfy: %r\ncx: %r\ncy: %r\nbaseline: %r\n"
                % (width, height, fx, fy, cx, cy, baseline))


# ---------------------------------------------------------------- messages
def image_msg(array, frame_id, stamp=None, encoding=None):
    """sensor_msgs/Image of a numpy image (mono8, bgr8 or bgra8 by its
    channels unless `encoding` is given)."""
    from sensor_msgs.msg import Image
    msg = Image()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = array.shape[:2]
    channels = 1 if array.ndim == 2 else array.shape[2]
    msg.encoding = encoding or {1: "mono8", 3: "bgr8", 4: "bgra8"}[channels]
    msg.step = msg.width * channels * array.dtype.itemsize
    msg.data = array.tobytes()
    return msg


def camera_info_msg(p, width, height, frame_id, stamp=None):
    """sensor_msgs/CameraInfo of a rectified camera with projection `p` (12
    entries): K from P, no distortion, identity R."""
    from sensor_msgs.msg import CameraInfo
    info = CameraInfo()
    if stamp is not None:
        info.header.stamp = stamp
    info.header.frame_id = frame_id
    info.width, info.height = width, height
    info.distortion_model = "plumb_bob"
    info.D = [0.0] * 5
    info.K = [p[0], 0.0, p[2], 0.0, p[5], p[6], 0.0, 0.0, 1.0]
    info.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    info.P = list(p)
    return info


def image_array(msg):
    """sensor_msgs/Image -> numpy (the encodings the nodelet publishes or takes;
    colour as BGR)."""
    import cv2
    import numpy as np
    dtypes = {"32FC1": (np.float32, 1), "mono8": (np.uint8, 1), "bgr8": (np.uint8, 3),
              "rgb8": (np.uint8, 3), "bgra8": (np.uint8, 4), "rgba8": (np.uint8, 4)}
    if msg.encoding not in dtypes:
        raise Failure("cannot read encoding %s" % msg.encoding)
    dtype, channels = dtypes[msg.encoding]
    dtype = np.dtype(dtype).newbyteorder(">" if msg.is_bigendian else "<")
    row = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.step)
    a = row[:, :msg.width * channels * dtype.itemsize].copy().view(dtype)
    a = a.reshape(msg.height, msg.width, channels) if channels > 1 else a.reshape(msg.height, msg.width)
    if msg.encoding in ("rgb8", "rgba8"):
        a = cv2.cvtColor(a, cv2.COLOR_RGB2BGR if channels == 3 else cv2.COLOR_RGBA2BGR)
    elif channels == 4:
        a = cv2.cvtColor(a, cv2.COLOR_BGRA2BGR)
    return a.astype(np.float32) if a.dtype.kind == "f" else a


def cloud_array(msg):
    """Structured numpy array (height x width) of a PointCloud2 whose fields
    are all 4 bytes (float32 x, y, z and the packed rgb)."""
    import numpy as np
    names = [f.name for f in msg.fields]
    dtype = np.dtype({"names": names, "formats": ["<f4"] * len(names),
                      "offsets": [f.offset for f in msg.fields], "itemsize": msg.point_step})
    return np.frombuffer(msg.data, dtype=dtype).reshape(msg.height, msg.width)


# ---------------------------------------------------------------- pictures
def colour_map(values, valid, lo, hi):
    """values in [lo, hi] as a turbo colour image (BGR), black where not valid."""
    import cv2
    import numpy as np
    scaled = np.zeros(values.shape, np.uint8)
    if hi > lo:
        scaled = np.clip((values - lo) / (hi - lo) * 255.0, 0, 255).astype(np.uint8)
    out = cv2.applyColorMap(scaled, cv2.COLORMAP_TURBO)
    out[~valid] = 0
    return out


def grey_panel(values):
    """values in [0, 1] as a grey BGR image (0 black, 1 white)."""
    import cv2
    import numpy as np
    return cv2.cvtColor((np.clip(values, 0, 1) * 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)


def labelled(panel, text, size):
    """The panel resized to size (width, height) with text on a black band."""
    import cv2
    panel = cv2.resize(panel, size, interpolation=cv2.INTER_AREA)
    cv2.rectangle(panel, (0, 0), (size[0], 18), (0, 0, 0), -1)
    cv2.putText(panel, text, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
    return panel


# ---------------------------------------------------------------- the ROS master
def master_online():
    import rosgraph
    return rosgraph.Master("/bdis_common").is_online()


def system_state():
    """({topic: [publishing node, ...]}, {topic: [subscribing node, ...]}) from
    the master at ROS_MASTER_URI; both empty while it is not reachable."""
    import rosgraph
    try:
        publishers, subscribers, _ = rosgraph.Master("/bdis_common").getSystemState()
    except Exception:  # not up yet, or going down
        return {}, {}
    return dict(publishers), dict(subscribers)


def publishers(topic):
    return system_state()[0].get(topic, [])


def subscribers(topic):
    return system_state()[1].get(topic, [])


def nodelet_loaded(name):
    """The bdis_stereo nodelet `name` (e.g. /stereo/bdis) is loaded: its
    dynamic_reconfigure server, set up at the end of its start-up, publishes."""
    return bool(publishers(name + "/parameter_updates"))


# ---------------------------------------------------------------- command line
def main():
    parser = argparse.ArgumentParser(description="Helpers of the bdis_stereo shell scripts.")
    commands = parser.add_subparsers(dest="command", required=True)
    commands.add_parser("free-port", help="print a TCP port free on loopback now")
    commands.add_parser("sample-dir", help="print the embedded sample's folder")
    master = commands.add_parser("wait-master", help="wait until the master at ROS_MASTER_URI answers")
    master.add_argument("--timeout", type=float, default=30.0)
    nodelet = commands.add_parser("wait-nodelet", help="wait until nodelet NAME is loaded")
    nodelet.add_argument("name")
    nodelet.add_argument("--unloaded", action="store_true", help="wait until it is unloaded")
    nodelet.add_argument("--timeout", type=float, default=60.0)
    args = parser.parse_args()
    try:
        if args.command == "free-port":
            print(free_port())
        elif args.command == "sample-dir":
            print(sample_dir())
        elif args.command == "wait-master":
            wait_for(master_online, args.timeout, "the ROS master", period=0.2)
        elif args.unloaded:
            wait_for(lambda: not nodelet_loaded(args.name), args.timeout,
                     "nodelet %s to unload" % args.name, period=0.1)
        else:
            wait_for(lambda: nodelet_loaded(args.name), args.timeout,
                     "nodelet %s to load" % args.name, period=0.1)
    except Failure as exc:
        print("bdis_common: %s" % exc, file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
