"""What the package's Python programs and tests share, written once: a free
port, the package's programs and embedded sample, camera.yaml, sensor_msgs
to and from numpy (raw, compressed, distorted as a camera would see a
rectified image), the montage panels and PLY clouds of bdis_demo and
disparity_montage.py, a bag's stereo inputs, waiting for a condition, what the
ROS master knows, and stopping a process group. Installed beside bdis_demo and
bdis_make_bag, which import it by path, as do the tests (test/demo, test/ros); the shell scripts reach it through
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


def camera_info_msg(p, width, height, frame_id, stamp=None, d=None, model="plumb_bob"):
    """sensor_msgs/CameraInfo of a camera with projection `p` (12 entries): K
    from P, identity R, and no distortion (a rectified camera) or `d` of
    `model` (a raw camera as its calibrator describes it)."""
    from sensor_msgs.msg import CameraInfo
    info = CameraInfo()
    if stamp is not None:
        info.header.stamp = stamp
    info.header.frame_id = frame_id
    info.width, info.height = width, height
    info.distortion_model = model
    info.D = list(d) if d is not None else [0.0] * 5
    info.K = [p[0], 0.0, p[2], 0.0, p[5], p[6], 0.0, 0.0, 1.0]
    info.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    info.P = list(p)
    return info


def parse_compression(spec):
    """--compress: "jpeg" (quality 95), "jpeg:Q" (Q in 1..100) or "png".
    Returns (format, quality or None); raises Failure."""
    fmt, _, quality = spec.partition(":")
    if fmt == "png" and not quality:
        return "png", None
    if fmt == "jpeg":
        try:
            q = int(quality) if quality else 95
        except ValueError:
            q = 0
        if 1 <= q <= 100:
            return "jpeg", q
    raise Failure("compression %r: give jpeg, jpeg:QUALITY (1..100) or png" % spec)


def compressed_image_msg(array, frame_id, compression, stamp=None):
    """sensor_msgs/CompressedImage of a mono8 or bgr8 numpy image, as
    compressed_image_transport writes it (format "bgr8; jpeg compressed bgr8")."""
    import cv2
    from sensor_msgs.msg import CompressedImage
    fmt, quality = parse_compression(compression)
    params = [cv2.IMWRITE_JPEG_QUALITY, quality] if fmt == "jpeg" else [cv2.IMWRITE_PNG_COMPRESSION, 3]
    ok, data = cv2.imencode(".jpg" if fmt == "jpeg" else ".png", array, params)
    if not ok:
        raise Failure("OpenCV cannot encode a %s image as %s" % (array.dtype, fmt))
    encoding = "mono8" if array.ndim == 2 else "bgr8"
    msg = CompressedImage()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.format = "%s; %s compressed %s" % (encoding, fmt, encoding)
    msg.data = data.tobytes()
    return msg


# Distortion coefficients of each model image_geometry undistorts.
DISTORTION_COEFFICIENTS = {"plumb_bob": 5, "rational_polynomial": 8, "equidistant": 4}


def distortion_vector(coefficients, model):
    """`coefficients` (k1, k2, ...) padded with zeros to the model's length."""
    if model not in DISTORTION_COEFFICIENTS:
        raise Failure("distortion model %r: one of %s" % (model, ", ".join(sorted(DISTORTION_COEFFICIENTS))))
    n = DISTORTION_COEFFICIENTS[model]
    if len(coefficients) > n:
        raise Failure("%s has %d distortion coefficients, not %d" % (model, n, len(coefficients)))
    return [float(c) for c in coefficients] + [0.0] * (n - len(coefficients))


def distort_image(image, k, d, model="plumb_bob"):
    """The raw image a camera with intrinsics `k` (3x3), distortion `d` of
    `model`, R = I and P = K takes of a scene whose rectified image is
    `image`: each raw pixel samples `image` (bilinear) where its ray meets
    the rectified image, found by undistorting the pixel. Black where that is
    outside. Test data for the raw input, not the pipeline's undistortion."""
    import cv2
    import numpy as np
    h, w = image.shape[:2]
    k = np.asarray(k, np.float64).reshape(3, 3)
    d = np.asarray(d, np.float64)
    xs, ys = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    pixels = np.stack([xs.ravel(), ys.ravel()], 1).reshape(-1, 1, 2)
    if model == "equidistant":
        rectified = cv2.fisheye.undistortPoints(pixels, k, d, R=np.eye(3), P=k)
    else:
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
        rectified = cv2.undistortPointsIter(pixels, k, d, np.eye(3), k, criteria)
    maps = rectified.reshape(h, w, 2).astype(np.float32)
    return cv2.remap(image, maps[..., 0], maps[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=0)


def image_array(msg):
    """sensor_msgs/Image or CompressedImage -> numpy (the encodings the
    nodelet publishes or takes; colour as BGR)."""
    import cv2
    import numpy as np
    if hasattr(msg, "format"):  # CompressedImage
        array = cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_UNCHANGED)
        if array is None:
            raise Failure("cannot decode a compressed image (format %r)" % msg.format)
        return array
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


# ---------------------------------------------------------------- the tools' 16-bit PNGs
def read_png16(path, scale):
    """A 16-bit single-channel PNG (bdis_match's disparity, confidence;
    ground truth) as float32 values / scale, and where it is non-zero."""
    import cv2
    import numpy as np
    raw = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if raw is None:
        raise Failure("cannot read %s" % path)
    if raw.dtype != np.uint16 or raw.ndim != 2:
        raise Failure("%s is not a 16-bit single-channel PNG" % path)
    return raw.astype(np.float32) / scale, raw > 0


# ---------------------------------------------------------------- pictures (bdis_demo, disparity_montage.py)
MONTAGE_PANEL = (320, 240)  # width, height of one panel


def colour_map(values, valid, lo, hi):
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


def labelled(panel, text, size=MONTAGE_PANEL):
    """The panel resized to size (width, height) with text on a black band."""
    import cv2
    panel = cv2.resize(panel, size, interpolation=cv2.INTER_AREA)
    cv2.rectangle(panel, (0, 0), (size[0], 18), (0, 0, 0), -1)
    cv2.putText(panel, text, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
    return panel


def write_montage(path, msgs, left_label):
    """left | disparity (turbo) / confidence (grey) | depth (turbo), from the
    messages of one frame: "left" (Image or CompressedImage), "disparity",
    "confidence", "depth"."""
    import cv2
    import numpy as np
    left = image_array(msgs["left"]) if msgs.get("left") is not None else None
    d = image_array(msgs["disparity"].image)
    valid = d >= 0
    if left is None:
        left = np.zeros(d.shape + (3,), np.uint8)
    elif left.ndim == 2:
        left = cv2.cvtColor(left, cv2.COLOR_GRAY2BGR)
    d_lo, d_hi = (np.percentile(d[valid], [1, 99]) if valid.any() else (0, 1))
    panels = [labelled(left, left_label),
              labelled(colour_map(d, valid, d_lo, d_hi),
                       "disparity %.0f-%.0f px (black: none)" % (d_lo, d_hi))]
    conf = image_array(msgs["confidence"]) if "confidence" in msgs else np.zeros_like(d)
    panels.append(labelled(grey_panel(conf), "confidence 0 (black) - 1 (white)"))
    depth = image_array(msgs["depth"]) if "depth" in msgs else np.full_like(d, np.nan)
    finite = np.isfinite(depth)
    z_lo, z_hi = (np.percentile(depth[finite], [1, 99]) if finite.any() else (0, 1))
    # Near is warm: reversed so the instrument stands out against the tissue.
    panels.append(labelled(colour_map(z_hi + z_lo - np.nan_to_num(depth, nan=z_hi), finite, z_lo, z_hi),
                           "depth %.3g-%.3g m (red: near)" % (z_lo, z_hi)))
    top = np.hstack(panels[:2])
    bottom = np.hstack(panels[2:])
    if not cv2.imwrite(path, np.vstack([top, bottom])):
        raise Failure("cannot write " + path)


def write_ply(path, cloud):
    """Binary little-endian PLY of the finite points, with colour when the
    cloud has the packed rgb field. Returns the number of points."""
    import numpy as np
    points = cloud_array(cloud).reshape(-1)
    if not all(k in points.dtype.names for k in "xyz"):
        raise Failure("points2 has no x, y, z fields")
    xyz = np.stack([points[k] for k in "xyz"], 1)
    finite = np.all(np.isfinite(xyz), axis=1)
    xyz = xyz[finite]
    if "rgb" in points.dtype.names:
        rgb = points["rgb"][finite].copy().view("<u4")
        colour = np.stack([(rgb >> 16) & 255, (rgb >> 8) & 255, rgb & 255], 1).astype(np.uint8)
    else:
        colour = np.full((len(xyz), 3), 200, np.uint8)
    vertex = np.empty(len(xyz), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                       ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    for i, k in enumerate("xyz"):
        vertex[k] = xyz[:, i]
    vertex["red"], vertex["green"], vertex["blue"] = colour[:, 0], colour[:, 1], colour[:, 2]
    header = ("ply\nformat binary_little_endian 1.0\ncomment bdis_stereo points2, frame %s\n"
              "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
              % (cloud.header.frame_id, len(vertex)))
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(vertex.tobytes())
    return len(vertex)


# ---------------------------------------------------------------- a bag's inputs
def bag_topic_types(bag_path):
    """{topic: message type} of a bag."""
    import rosbag
    with rosbag.Bag(bag_path) as bag:
        return {name: t.msg_type for name, t in bag.get_type_and_topic_info().topics.items()}


def bag_image_topic(types, topic):
    """Where the images of `topic` (a base name, or one ending in /compressed)
    are in a bag with topics `types`: (bag topic, base topic, compressed), or
    None. sensor_msgs/Image on the topic itself, sensor_msgs/CompressedImage
    on it or on <topic>/compressed."""
    base = topic[:-len("/compressed")] if topic.endswith("/compressed") else topic
    for candidate in (topic, base + "/compressed"):
        kind = types.get(candidate)
        if kind == "sensor_msgs/Image":
            return candidate, base, False
        if kind == "sensor_msgs/CompressedImage":
            return candidate, base, True
    return None


def stereo_bag_inputs(types, left_image, right_image):
    """The two image topics of a bag: ((bag topic, base topic) left, right),
    compressed, raw. Raw (to rectify) when the base topics end in image_raw.
    Raises Failure when a topic is missing or the two differ in kind."""
    found = []
    for side, topic in (("left", left_image), ("right", right_image)):
        where = bag_image_topic(types, topic)
        if where is None:
            images = sorted(t for t, kind in types.items() if kind.startswith("sensor_msgs/") and "Image" in kind)
            raise Failure("the bag has no images on %s (nor %s/compressed); its image topics: %s; name them with "
                          "--%s-image" % (topic, topic, ", ".join(images) or "none", side))
        found.append(where)
    if found[0][2] != found[1][2]:
        raise Failure("one image topic is compressed and the other is not: %s, %s" % (found[0][0], found[1][0]))
    raw = [f[1].endswith("image_raw") for f in found]
    if raw[0] != raw[1]:
        raise Failure("one image topic is raw and the other is not: %s, %s" % (found[0][1], found[1][1]))
    return (found[0][:2], found[1][:2]), found[0][2], raw[0]


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
