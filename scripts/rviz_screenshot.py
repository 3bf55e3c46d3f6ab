"""Reads a screenshot of rviz with rviz/bdis_stereo.rviz: where the 3-D view
is, how much of it the cloud covers, and whether the Displays panel shows a
warning or error status (rviz draws those rows' names and icons orange or red;
an Ok row is black or blue). bdis_demo --screenshot captures the screen
until the cloud shows (cloud_problem, status_problem); the demo's test checks
the screenshot it saved."""
import cv2
import numpy as np

RENDER_BACKGROUND = (48, 48, 48)  # "Background Color" of the config (grey: BGR = RGB)
MIN_VIEW_SHARE = 0.05  # of the screen: a smaller region of the background colour is no 3-D view
MIN_CENTRE_CLOUD_SHARE = 0.6  # of the middle of the 3-D view; the sample fills about 0.9


def _largest_component(mask):
    count, _, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=4)
    if count < 2:
        return None
    i = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return tuple(int(v) for v in stats[i, :4])  # x, y, w, h


def _text_rows(mask, min_span=24):
    """Rows where the colour spans text (a status drawn in the name), not an
    icon: the Axes display's icon has a small red axis, 16 px wide at most."""
    rows = 0
    for row in mask:
        xs = np.flatnonzero(row)
        rows += int(len(xs) >= 3 and xs[-1] - xs[0] >= min_span)
    return rows


def analyse(path):
    image = cv2.imread(path, cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError("cannot read %s" % path)
    result = {"size": image.shape[1::-1]}
    # The 3-D view: the largest region of the background colour (the cloud
    # leaves holes in it, but the panel's border stays connected).
    background = np.all(image == RENDER_BACKGROUND, axis=2)
    view = _largest_component(background)
    result["view"] = view
    if view is None:
        return result
    x, y, w, h = view
    # The view looks at the cloud: it fills the middle of the panel.
    centre = background[y + h // 4:y + 3 * h // 4, x + w // 4:x + 3 * w // 4]
    result["centre_cloud_share"] = float(1.0 - centre.mean()) if centre.size else 0.0
    result["view_cloud_share"] = float(1.0 - background[y:y + h, x:x + w].mean())
    # The Displays tree: the rows of the largest white region left of the
    # 3-D view (its value column), across the whole panel (names and icons).
    left = image[:, :max(x - 4, 1)]
    tree = _largest_component(np.all(left >= 250, axis=2))
    result["tree"] = tree
    if tree is not None:
        _, ty, _, th = tree
        hsv = cv2.cvtColor(left[ty:ty + th], cv2.COLOR_BGR2HSV)
        vivid = (hsv[..., 1] > 120) & (hsv[..., 2] > 90)
        hue = hsv[..., 0].astype(int)  # OpenCV: 0..179
        red = vivid & ((hue >= 170) | (hue <= 4))
        orange = vivid & (hue >= 8) & (hue <= 25)
        result["status_red_rows"] = _text_rows(red)
        result["status_orange_rows"] = _text_rows(orange)
    return result


def cloud_problem(result):
    """Why an analysed screenshot does not show the cloud, or None."""
    width, height = result["size"]
    if result["view"] is None or result["view"][2] * result["view"][3] < MIN_VIEW_SHARE * width * height:
        return "no 3-D view (rviz not drawn yet, or hidden)"
    if not result["centre_cloud_share"] >= MIN_CENTRE_CLOUD_SHARE:
        return "no cloud in the 3-D view (it covers %.0f %% of the view's middle)" % (
            100 * result["centre_cloud_share"])
    return None


def status_problem(result):
    """The warning or error statuses of the Displays panel, or None (also when
    the panel is not found, e.g. under a dark theme)."""
    red, orange = result.get("status_red_rows", 0), result.get("status_orange_rows", 0)
    if red or orange:
        return "the Displays panel shows errors or warnings (%d red, %d orange rows of text)" % (red, orange)
    return None
