"""Any detected object located in 3D: match detections across a stereo pair, triangulate, track.

``StereoObjectPerception`` runs its detectors on both views of a ``StereoFrame``; detections of
the same kind and label whose rectified centres lie on the same row (epipolar consistency, within
``max_dy_px``), with a positive disparity, a similar size (radius and box sides) and a 3D point
that can be an object on the desk (not below the desk plane, not above the cameras), are paired
(greedily, cheapest first: row offset plus size mismatch). Each pair's rectified centres are
triangulated into camera_left and mapped to robot_base with the calibration's rectification,
exactly as the marker perception does (``StereoMarkerPerception.rectify_points`` /
``triangulate_rectified`` / ``camera_to_base``: point-wise ``cv2.undistortPoints``).

Ids. Each 3D point is associated with the live track of the same kind and label whose
constant-velocity Kalman prediction is nearest (within ``gate_m``; confirmed tracks before
tentative ones). A point with none starts a *tentative* track, which gets a public id and is
reported only after ``min_hits`` triangulated frames in a row (SORT's min_hits: a flicker never
gets an id). A confirmed track unseen for ``drop_after`` frames is lost; a lost one is remembered
``LOST_KEEP_S`` and takes its id back when its object reappears near where it was lost.

Occlusion. The arm or a hand across an object splits its blob in two; each half would start a
track of its own and later take the object's id. So, per view, same-label blobs inside a live
track's predicted box whose union still fits the track's known size (``merge_fragments``) are
merged into one detection (their convex hull: the occluder's strip between them is the object
too); a leftover blob that would start a track inside the box of a track measured this frame is
a fragment and starts none; and one blob covering two tracks of its label (a fragment track and
its object, seen whole again) keeps the older track's id.

ROI search (``roi_search``): between full-frame searches each detector runs only in a window
around each live track's predicted box in each view (grown by ``roi_margin`` box sizes and by
its image motion). A full-frame search runs every ``full_frame_every`` frames (a new object can
appear only then) and whenever a track is tentative or missed a frame, or a blob touches its
window's edge. ``last_full_frame_search`` and ``last_timings_ms`` describe the last frame.

Alternating views (``alternate_views``; by default when every detector is ``heavy``, a network a
view such as the desk detector): between full searches — every ``full_frame_every`` frames, on every
frame while a track is new, and on the ALTERNATE_MISSED_FULL frames after a track is missed — the
detectors run in the left view only, and only on every ``left_detect_every``-th frame (3). On the
frames between ("follow"), each track seen on the last frame is found again in the left view by its
patch in the last frame (around its box moved by its image velocity; a blob's outline goes along,
for its sub-pixel centre); a box whose patch is not found gets the left view searched after all.
The right view's boxes are stand-ins: each track's left box moved by its stereo offset (the right
centre minus the left one when last measured in both), placed where the left view's patch of the
object matches (``stereo_matched_centre``). A full search's right boxes are placed so too when that
moves them ≤ FULL_PLACE_MAX_PX, so an object's depth is measured the same way on every frame.
Objects run, desk detector, 45 s on the simulated clock: 0.57 network passes a frame (both views on
every frame: 2; the left view searched on every frame between full searches: 1.16), moving objects'
3D error p50/p95 2.28/4.05 mm (both views every frame: 3.23/9.67), velocity error p50 4.4 mm/s
(15.5), no id switch; a followed box is no worse than a searched one (the network's boxes jitter).

Trackers (``tracker`` = "kcf", "csrt", "mil", "mosse"): each confirmed track runs a
``core.detect.tracking.ObjectTracker`` per view, seeded from its detection, re-seeded from the
detector every ``reseed_every`` frames or when they disagree. On a frame where the detector
misses the object in a view (or is not run: ``detect_every`` > 1), the tracker's box stands in
for that view's detection. While the detector sees the object the tracker is not run: it only
notes the detection (``ObjectTracker.observe``) and is re-seeded from it when next needed —
the OpenCV tracker and its appearance check cost ~10 ms per object and view on this machine. The tracker's removal check (``lost_after`` detector runs without a
matching detection, or a patch that looks like the background) ends that: a tracker never
reports an object that left or is hidden for long.

Several detectors (``fuse_circles``): a colour blob and a circle/ellipse on it are one object
(``fuse_round_tops``): the circle is dropped, and when the ellipse is the blob's round top face
(a disc, a cylinder, an upside-down cup, seen obliquely: an ellipse, not a circle) the blob
takes the top's centre. So ``hsv`` + ``circles`` give one track per coloured object, located at its top; circles
on nothing coloured (a white cup) stay "circle" tracks.

Unsynchronised webcams: the right image of a pair is captured ``frame.skew_s`` after the left
(``frame.t``). A moving object has moved in between and that motion reads as false disparity
(0.2 m/s sideways, 16 ms: ~27 mm of depth at 50 cm). With ``compensate_skew`` each track
estimates both views' image velocities (rectified px/s) from its last matched centres and their
capture times, and the right centre is brought back to the left view's instant
(``core.detect.skew.compensate_pair``) before triangulating. A new track (no velocity yet) is
triangulated as seen.
"""
from __future__ import annotations

import collections
import math
import time
from dataclasses import dataclass, replace
from typing import Optional, Sequence

import cv2
import numpy as np

from core.detect.base import Detection, Detector, clip_roi
from core.detect.kalman import ConstantVelocityKalman
from core.detect.skew import compensate_pair
from core.messages import StereoFrame
from core.vision.calibration import StereoCalibration
from core.vision.perception import StereoMarkerPerception


@dataclass(frozen=True, eq=False)
class ObjectObservation:
    """One object of this frame, with its stable id.

    Triangulated objects (``triangulated``: seen in both views and matched) carry the measured
    ``camera_p`` / ``base_p`` of this frame (skew-compensated when enabled). A tracked object seen
    in one view only is reported with that view's detection, ``triangulated`` False and the
    track's predicted position (not a measurement).
    """

    object_id: int
    kind: str
    label: str
    score: float  # the lower score of the two views' detections (or the one view's)
    left: Optional[Detection]  # raw-image detection in the left view (None: not seen there)
    right: Optional[Detection]
    camera_p: Optional[tuple[float, float, float]]  # camera_left (m)
    base_p: Optional[tuple[float, float, float]]  # robot_base (m)
    velocity_base: Optional[tuple[float, float, float]]  # robot_base (m/s) from the track's Kalman; None when new
    epipolar_dy_px: Optional[float]  # rectified row of left centre − right centre (as seen, before compensation)
    seen_left: bool
    seen_right: bool
    triangulated: bool = True
    disparity_px: Optional[float] = None  # rectified x_left − x_right used for triangulation
    skew_compensated: bool = False  # the right centre was moved to the left view's instant
    frames_tracked: int = 1  # triangulated frames of this track so far
    from_tracker: bool = False  # a view's observation is its tracker's box (the detector missed it there)


# A tracker's box is 0.4–2 px off the object in each view, and independently so in the two views:
# stereo turns 1 px of disparity into ~10 mm of depth at 50 cm (f 430 px, B 6 cm). Where a view's
# box comes from its tracker, it is re-placed by finding the other view's patch of the object
# near it (normalised cross-correlation, sub-pixel): the disparity is then measured, not the
# difference of two trackers' errors.
# alternating views: a track missed this many frames in a row gets both views searched on each;
# after that it is hidden (behind the arm, a hand) and the periodic full searches look for it
# (the left view's search finds it on the frames between, where its predicted right box is placed)
ALTERNATE_MISSED_FULL = 2
PREDICTED_VIEW_GATE_PX = 60.0  # a searched view's detection this near a track's predicted box (or 2 box sizes) is its
STEREO_MATCH_PX = 6  # the search around the tracker's box, each way
STEREO_MATCH_MIN_NCC = 0.6  # a weaker match leaves the tracker's box as it was


def _parabola_peak(before: float, peak: float, after: float) -> float:
    """Sub-pixel offset (−0.5…0.5) of a peak from its two neighbours."""
    denom = before - 2.0 * peak + after
    return 0.0 if denom >= 0 else float(np.clip(0.5 * (before - after) / denom, -0.5, 0.5))


def stereo_matched_centre(template_image: np.ndarray, template: Detection, image: np.ndarray,
                          guess: Detection, margin_px: int = STEREO_MATCH_PX,
                          min_ncc: float = STEREO_MATCH_MIN_NCC,
                          centre: Optional[tuple[float, float]] = None) -> Optional[tuple[float, float]]:
    """Where ``template``'s centre (a detection in ``template_image``; ``centre`` when given, e.g.
    its sub-pixel blob centre) is in ``image``: its patch looked for within ``margin_px`` of
    ``guess``'s box (the other view's tracker box), to a fraction of a pixel. The search area is
    cut to the image: an object near its border is still found. None when the patch is cut by its
    image's border, the area left is smaller than it, or it matches too weakly."""
    # the whole box: a plain ball's only texture is its outline against the desk (its middle
    # alone matched 3x worse)
    x, y, w, h = (int(round(v)) for v in template.box)
    H, W = template_image.shape[:2]
    if w < 4 or h < 4 or x < 0 or y < 0 or x + w > W or y + h > H:
        return None
    gx, gy = (int(round(v)) for v in guess.box[:2])
    # the search area, cut to the image (an object near the border is still found inside it)
    x0, y0 = max(gx - margin_px, 0), max(gy - margin_px, 0)
    x1, y1 = min(gx + w + margin_px, image.shape[1]), min(gy + h + margin_px, image.shape[0])
    if x1 - x0 < w or y1 - y0 < h:
        return None
    patch = cv2.cvtColor(template_image[y:y + h, x:x + w], cv2.COLOR_BGR2GRAY)
    area = cv2.cvtColor(image[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY)
    score = cv2.matchTemplate(area, patch, cv2.TM_CCOEFF_NORMED)
    _, best, _, (px, py) = cv2.minMaxLoc(score)
    if not best >= min_ncc:
        return None
    dx = _parabola_peak(score[py, px - 1], best, score[py, px + 1]) if 0 < px < score.shape[1] - 1 else 0.0
    dy = _parabola_peak(score[py - 1, px], best, score[py + 1, px]) if 0 < py < score.shape[0] - 1 else 0.0
    cx, cy = template.centre_px if centre is None else centre
    return (x0 + px + dx + (cx - x), y0 + py + dy + (cy - y))


def _centred_on(stand_in: Detection, source: Detection) -> Detection:
    """A box of ``source``'s size centred where ``stand_in`` is: where ``stereo_matched_centre``
    looks for ``source``'s patch (a predicted stand-in is the track's size, the patch the detection's)."""
    w, h = source.box[2], source.box[3]
    cx, cy = stand_in.centre_px
    return replace(stand_in, box=(cx - w / 2.0, cy - h / 2.0, w, h))


def _size(d: Detection) -> float:
    """A detection's size (px): its radius when it has one, else half the box's geometric mean side."""
    if d.radius_px is not None and d.radius_px > 0:
        return float(d.radius_px)
    w, h = d.box[2], d.box[3]
    return max(0.5, 0.5 * math.sqrt(max(w, 0.0) * max(h, 0.0)))


_K3 = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))  # blob_centre's erosions and dilations


def blob_centre(image: Optional[np.ndarray], d: Detection, grow_px: int = 2) -> tuple[float, float]:
    """The centre to triangulate: for a blob (a detection with an outline) a sub-pixel centroid,
    else ``centre_px``.

    A thresholded blob's centroid moves in steps as the object crosses the pixel grid: at 18 px
    radius up to ~0.15 px (whole columns at the left and right extremes switch at once), which is
    ~1.5 mm of depth at 50 cm. Here every pixel within ``grow_px`` of the outline is weighted by
    where its colour lies between the blob's inside (the outline eroded) and the local
    background (a ring just outside): the edge pixels' partial coverage (anti-aliasing, blur)
    counts as a fraction. Without ``image``, or when inside and background are too alike, the
    centroid of the enclosed pixels.
    """
    if d.contour is None or len(d.contour) < 3:
        return d.centre_px
    pts = np.round(d.contour).astype(np.int32)
    pad = grow_px + 4
    bx, by, bw, bh = cv2.boundingRect(pts)  # Python ints: the box arithmetic below stays off numpy
    x0, y0, x1, y1 = bx - pad, by - pad, bx + bw + pad, by + bh + pad
    if (x1 - x0) * (y1 - y0) > 4_000_000:  # a huge blob: the outline centroid is plenty
        return d.centre_px
    mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.drawContours(mask, [pts.reshape(-1, 1, 2)], 0, 255, -1, offset=(-x0, -y0))

    def area_centre() -> tuple[float, float]:  # the enclosed pixels' centroid (only when returned)
        m = cv2.moments(mask, binaryImage=True)
        if m["m00"] <= 0:
            return d.centre_px
        return (float(x0 + m["m10"] / m["m00"]), float(y0 + m["m01"] / m["m00"]))

    if image is None or image.ndim != 3:
        return area_centre()
    H, W = image.shape[:2]
    if x0 < 0 or y0 < 0 or x1 > W or y1 > H:
        return area_centre()  # at the image border: the ring is cut off
    inner = cv2.erode(mask, _K3, iterations=2)
    # the dilations grow one from the other (dilating n then m times is dilating n + m times):
    # 5 passes instead of 2 + 6 + 4
    near = cv2.dilate(mask, _K3, iterations=grow_px) if grow_px > 0 else mask
    outside = cv2.dilate(near, _K3, iterations=1)
    ring = cv2.dilate(outside, _K3, iterations=2) & ~outside
    if cv2.countNonZero(inner) < 8 or cv2.countNonZero(ring) < 8:
        return area_centre()
    # OpenCV's masked means, affine transform and moments instead of numpy's boolean indexing,
    # matrix product and sums: the same figures (to float rounding) in a fifth of the time; the
    # three-element sums in Python floats (numpy's small-array calls cost more than the sums)
    patch = image[y0:y1, x0:x1]
    f0, f1, f2, _ = cv2.mean(patch, mask=inner)
    b0, b1, b2, _ = cv2.mean(patch, mask=ring)
    s0, s1, s2 = f0 - b0, f1 - b1, f2 - b2
    n2 = s0 * s0 + s1 * s1 + s2 * s2
    if n2 < 20.0 ** 2:
        return area_centre()
    # w = (pixel − bg)·span / |span|², clipped to 0…1: 1 inside, 0 outside ``near``
    w = cv2.transform(patch.astype(np.float32),
                      np.array([[s0 / n2, s1 / n2, s2 / n2, -(b0 * s0 + b1 * s1 + b2 * s2) / n2]]))
    np.clip(w, 0.0, 1.0, out=w)
    w[near == 0] = 0.0
    w[inner > 0] = 1.0
    m = cv2.moments(w)
    if m["m00"] <= 0:
        return area_centre()
    return (float(x0 + m["m10"] / m["m00"]), float(y0 + m["m01"] / m["m00"]))


def _point(p) -> tuple[float, float, float]:
    return tuple(float(v) for v in np.asarray(p, dtype=float).reshape(3))


REACQUIRE_M = 0.20  # a live track's last position this near takes a detection its prediction missed
LOST_KEEP_S = 8.0  # a lost track is remembered this long, for an object that leaves and comes back
LOST_REACQUIRE_M = 0.40  # … and takes a detection of its label this near its last position
SIDES = ("left", "right")
FULL_PLACE_MAX_PX = 3.0  # alternating views: a full search's right box is placed from the left patch within this
TRACKER_KINDS = ("kcf", "csrt", "mil", "mosse")  # ``tracker=``: core.detect.tracking kinds, lower case
EXTENT_HISTORY = 30  # a track's size in a view: the largest box of its last this many whole detections
MERGE_SLACK = 1.25  # fragments merge when their union is at most this many times the track's size …
MERGE_PAD_PX = 4.0  # … plus this much
# fragments are looked for in a track's predicted box grown by this much of its size on each side
# (the box follows the last measurement, itself a fragment's once the occlusion began)
MERGE_GROW = 0.5
FRAGMENT_GROW = 0.25  # a pair inside a measured track's predicted boxes grown by this much starts no track
ROI_MIN_MARGIN_PX = 6.0  # an ROI is at least this much larger than the predicted box on each side


class _ObjectTrack:
    """What the perception remembers about one object between frames."""

    def __init__(self, key: int, kind: str, label: str, kalman: ConstantVelocityKalman, history: int):
        self.key = key  # internal, from birth; ``object_id`` is the public id, given at confirmation
        self.object_id: Optional[int] = None
        self.kind, self.label = kind, label
        self.kf = kalman
        self.missed = 0  # frames in a row without a triangulated measurement
        self.score = 1.0  # of the last whole detection (a predicted box for an unsearched view keeps it)
        self.frames = 0  # triangulated frames
        self.hits = 0  # triangulated frames in a row
        # rectified centres as seen, with their capture times: (t, x, y)
        self.left_hist: collections.deque = collections.deque(maxlen=history)
        self.right_hist: collections.deque = collections.deque(maxlen=history)
        # per view: the last raw box seen (t, x, y, w, h, radius) and the sizes (w, h) of whole detections
        self.view: dict[str, Optional[tuple]] = {side: None for side in SIDES}
        # the right view's centre minus the left view's at the last frame measured in both
        self.stereo_offset: Optional[tuple[float, float]] = None
        self.outline: dict[str, Optional[np.ndarray]] = {side: None for side in SIDES}  # at view's box
        self.extent: dict[str, collections.deque] = {side: collections.deque(maxlen=EXTENT_HISTORY) for side in SIDES}
        self.trackers: dict[str, object] = {side: None for side in SIDES}  # ObjectTracker per view
        # per view: the last image velocity and size with what they came from (the deques' end items,
        # held so that their identity stays theirs): a frame asks for them a few dozen times
        self._velocity_memo: dict[str, tuple] = {}
        self._size_memo: dict[str, tuple] = {}

    @property
    def confirmed(self) -> bool:
        return self.object_id is not None

    def predicted(self, t: float) -> Optional[np.ndarray]:
        p, v = self.kf.position, self.kf.velocity
        if p is None:
            return None
        return p + v * max(0.0, t - self.kf.t)

    @staticmethod
    def _velocity(hist) -> Optional[np.ndarray]:
        """Image velocity (px/s): least-squares slope of the stored centres against time."""
        n = len(hist)
        if n < 2:
            return None
        # a handful of (t, x, y) in Python floats: numpy's array and reductions cost 10x more here
        mt = sum(h[0] for h in hist) / n
        mx = sum(h[1] for h in hist) / n
        my = sum(h[2] for h in hist) / n
        den = sx = sy = 0.0
        for t, x, y in hist:
            dt = t - mt
            den += dt * dt
            sx += dt * (x - mx)
            sy += dt * (y - my)
        if den <= 1e-12:
            return None
        return np.array([sx / den, sy / den])

    def velocities(self):
        return self._velocity(self.left_hist), self._velocity(self.right_hist)

    def image_velocity(self, side: str) -> Optional[np.ndarray]:
        """``side``'s image velocity (px/s, see _velocity); computed again only when its history
        changed (the deques only append, pop and clear: same length and same end items, same content)."""
        hist = self.left_hist if side == "left" else self.right_hist
        if len(hist) < 2:
            return None
        memo = self._velocity_memo.get(side)
        if memo is not None and memo[0] is hist[0] and memo[1] is hist[-1] and memo[2] == len(hist):
            return memo[3]
        velocity = self._velocity(hist)
        self._velocity_memo[side] = (hist[0], hist[-1], len(hist), velocity)
        return velocity

    def size(self, side: str) -> Optional[tuple[float, float]]:
        """The object's box size (w, h) in ``side``: the largest of its recent whole detections."""
        sizes = self.extent[side]
        if sizes:
            memo = self._size_memo.get(side)
            if memo is not None and memo[0] is sizes[0] and memo[1] is sizes[-1] and memo[2] == len(sizes):
                return memo[3]
            size = (max(w for w, _ in sizes), max(h for _, h in sizes))
            self._size_memo[side] = (sizes[0], sizes[-1], len(sizes), size)
            return size
        v = self.view[side]
        return None if v is None else (v[3], v[4])

    def predicted_box(self, side: str, t: float) -> Optional[np.ndarray]:
        """Where the object's box (x, y, w, h; raw px, its full size) is expected in ``side`` at ``t``."""
        v = self.view[side]
        if v is None:
            return None
        t0, x, y, w, h, _ = v
        cx, cy = x + w / 2.0, y + h / 2.0
        vel = self.image_velocity(side)
        if vel is not None:
            dt = min(max(t - t0, 0.0), 0.5)
            cx, cy = cx + float(vel[0]) * dt, cy + float(vel[1]) * dt
        W, H = self.size(side)
        return np.array([cx - W / 2.0, cy - H / 2.0, W, H])

    def note_view(self, side: str, t: float, d: Detection, whole: bool) -> None:
        """Remember the box ``d`` of this object in ``side`` (``whole``: a detector's own blob)."""
        x, y, w, h = d.box
        self.view[side] = (t, x, y, w, h, _size(d))
        self.outline[side] = d.contour  # a blob's outline, followed with its box (None: a box only)
        if whole:
            self.extent[side].append((w, h))
            self.score = d.score


def _inside(point, box, grow: float = 0.0) -> bool:
    """Is ``point`` (x, y) inside ``box`` (x, y, w, h) grown by ``grow`` of its size on each side?"""
    x, y, w, h = box
    gx, gy = grow * w, grow * h
    return x - gx <= point[0] <= x + w + gx and y - gy <= point[1] <= y + h + gy


def _boxes_touch(a, b) -> bool:
    return a[0] <= b[0] + b[2] and b[0] <= a[0] + a[2] and a[1] <= b[1] + b[3] and b[1] <= a[1] + a[3]


def _merge_boxes(boxes: list) -> list:
    """Overlapping boxes (x, y, w, h) replaced by their union until none overlap."""
    boxes = [list(map(float, b)) for b in boxes]
    merged = True
    while merged:
        merged = False
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                if _boxes_touch(boxes[i], boxes[j]):
                    a, b = boxes[i], boxes.pop(j)
                    x0, y0 = min(a[0], b[0]), min(a[1], b[1])
                    x1, y1 = max(a[0] + a[2], b[0] + b[2]), max(a[1] + a[3], b[1] + b[3])
                    boxes[i] = [x0, y0, x1 - x0, y1 - y0]
                    merged = True
                    break
            if merged:
                break
    return boxes


TOP_FACE_WIDTH = 0.5  # an ellipse on a colour blob spans at least this much of the blob's width (a cup widens below its top)
TOP_FACE_SLACK_PX = 4.0  # the ellipse's box lies inside the blob's box grown by this much
# … and it is an ellipse, not a circle: a round top seen obliquely (~0.7–0.88 at the default
# rig); a ball's outline is a circle from anywhere (~1)
TOP_FACE_MAX_ASPECT = 0.9


def _aspect(d: Detection) -> float:
    """Minor / major axis of a detection's outline (its second moments), 1 without an outline."""
    if d.contour is None or len(d.contour) < 5:
        return 1.0
    pts = np.asarray(d.contour, float)
    ev = np.linalg.eigvalsh(np.cov((pts - pts.mean(axis=0)).T))
    return float(math.sqrt(max(ev[0], 0.0) / ev[1])) if ev[1] > 0 else 1.0


def fuse_round_tops(detections: Sequence[Detection]) -> tuple[list[Detection], set]:
    """One detection per physical object when a colour blob and a circle/ellipse see the same thing.

    A "circle" detection whose centre lies on a colour blob (inside its outline) and whose box
    lies inside the blob's box is that blob's object, and is dropped (the colour names it).
    When the ellipse also spans most of the blob's width (``TOP_FACE_WIDTH``) and is not a
    circle (``TOP_FACE_MAX_ASPECT``), it is the object's round top face seen obliquely (a disc's,
    a cylinder's, an upside-down cup's) and the blob is top plus side: the blob's detection takes
    the ellipse's centre (the top face's middle, where the truth point of such objects is and
    what an arm would aim at; the blob's centroid lies about half the side's height lower:
    ~2 cm on the 4.5 cm purple cylinder, ~3.5 cm on a cup), keeping its own box, radius and
    outline (sizes stay comparable with the other view). A ball's outline is a circle: its
    blob's centroid stays. An object whose top is not found in one view is triangulated from
    the top in one view and the centroid in the other for that frame (a worse point, or no
    pair): the ellipse detector finds these tops in ~98 % of views.

    Returns the detections and the ``id()`` of the blobs given an ellipse's centre (their centre
    must not be refined from the outline again)."""
    blobs = [d for d in detections if d.kind == "colour" and d.contour is not None and len(d.contour) >= 3]
    if not blobs:
        return list(detections), set()
    circles = [d for d in detections if d.kind == "circle"]
    if not circles:
        return list(detections), set()
    outlines = {id(b): np.asarray(b.contour, np.float32).reshape(-1, 1, 2) for b in blobs}
    absorbed: set = set()
    tops: dict[int, Detection] = {}  # id(blob) -> its top face
    for c in circles:
        cx, cy = c.centre_px
        x, y, w, h = c.box
        for b in blobs:
            bx, by, bw, bh = b.box
            k = TOP_FACE_SLACK_PX
            if not (bx - k <= x and by - k <= y and x + w <= bx + bw + k and y + h <= by + bh + k):
                continue
            if cv2.pointPolygonTest(outlines[id(b)], (float(cx), float(cy)), False) < 0:
                continue
            absorbed.add(id(c))
            if w >= TOP_FACE_WIDTH * bw and _aspect(c) <= TOP_FACE_MAX_ASPECT:
                best = tops.get(id(b))
                if best is None or c.box[2] * c.box[3] > best.box[2] * best.box[3]:
                    tops[id(b)] = c  # the largest ellipse on the blob is its top
            break
    out, fused = [], set()
    for d in detections:
        if id(d) in absorbed:
            continue
        top = tops.get(id(d))
        if top is not None:
            d = replace(d, centre_px=top.centre_px, score=min(d.score, top.score))
            fused.add(id(d))
        out.append(d)
    return out, fused


def merge_detections(parts: Sequence[Detection]) -> Detection:
    """One detection standing for the fragments ``parts`` of one object (same kind and label).

    Its outline is the convex hull of the parts' outlines (or boxes): an occluder's strip between
    the fragments belongs to the object too. Centre: the hull's centroid; score: the lowest.
    """
    pts = []
    for d in parts:
        if d.contour is not None and len(d.contour) >= 1:
            pts.append(np.asarray(d.contour, float))
        else:
            x, y, w, h = d.box
            pts.append(np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]], float))
    hull = cv2.convexHull(np.vstack(pts).astype(np.float32)).reshape(-1, 2).astype(np.float64)
    m = cv2.moments(hull.astype(np.float32))
    if m["m00"] > 0:
        centre = (m["m10"] / m["m00"], m["m01"] / m["m00"])
    else:
        centre = tuple(hull.mean(axis=0))
    lo, hi = hull.min(axis=0), hull.max(axis=0)
    (_, _), radius = cv2.minEnclosingCircle(hull.astype(np.float32))
    first = parts[0]
    return Detection(kind=first.kind, label=first.label, score=min(d.score for d in parts),
                     box=(lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]), centre_px=centre,
                     radius_px=float(radius), contour=hull)


def _nearest_of_label(tracks, d: Detection, p: np.ndarray, taken: set, within_m: float) -> Optional["_ObjectTrack"]:
    """The track of ``d``'s kind and label, not in ``taken``, whose last position is nearest to
    ``p`` and closer than ``within_m``; None when there is none."""
    best, best_dist = None, within_m
    for track in tracks:
        if track.key in taken or track.kind != d.kind or track.label != d.label:
            continue
        last = track.kf.position
        if last is None:
            continue
        dist = float(np.linalg.norm(p - last))
        if dist < best_dist:
            best, best_dist = track, dist
    return best


class StereoObjectPerception:
    """Detections of any ``Detector`` in both views → matched pairs → robot_base points with ids.

    ``base_T_camera`` is the 4x4 pose of camera_left in robot_base. ``detectors`` each run on
    both raw views (or only in windows around the tracks: ``roi_search``). Not thread-safe: one
    per worker. See the module docstring for ids, fragments, ROI search and trackers.
    """

    def __init__(self, calibration: StereoCalibration, base_T_camera, detectors: Sequence[Detector],
                 max_dy_px: float = 4.0, min_disparity_px: float = 1.0, size_ratio: float = 1.6,
                 compensate_skew: bool = True, gate_m: float = 0.08, drop_after: int = 10,
                 velocity_history: int = 5, max_history_gap_s: float = 0.25,
                 process_noise: float = 0.5, measurement_noise: float = 0.002, refine_centres: bool = True,
                 min_hits: int = 3, desk_check: bool = True, min_z_m: float = -0.01, max_z_m: Optional[float] = None,
                 merge_fragments: bool = True, roi_search: bool = False, full_frame_every: int = 10,
                 roi_margin: float = 0.5, tracker: Optional[str] = None, reseed_every: int = 5,
                 detect_every: int = 1, tracker_lost_after: int = 5, fuse_circles: bool = True,
                 alternate_views: Optional[bool] = None, left_detect_every: int = 3):
        if not (isinstance(left_detect_every, int) and left_detect_every >= 1):
            raise ValueError(f"left_detect_every = {left_detect_every!r} must be a whole number ≥ 1 (1: every frame)")
        if not (max_dy_px > 0 and min_disparity_px >= 0 and size_ratio >= 1.0 and gate_m > 0):
            raise ValueError("max_dy_px and gate_m must be > 0, min_disparity_px ≥ 0 and size_ratio ≥ 1")
        if drop_after < 1 or velocity_history < 2:
            raise ValueError("drop_after must be ≥ 1 and velocity_history ≥ 2")
        if not (isinstance(min_hits, int) and min_hits >= 1):
            raise ValueError(f"min_hits = {min_hits!r} must be a whole number ≥ 1 (1: report new objects at once)")
        if not (isinstance(full_frame_every, int) and full_frame_every >= 1):
            raise ValueError(f"full_frame_every = {full_frame_every!r} must be a whole number ≥ 1 (1: every frame)")
        if not (0.0 <= roi_margin <= 10.0):
            raise ValueError(f"roi_margin = {roi_margin!r} must be 0…10 box sizes")
        if not (isinstance(reseed_every, int) and reseed_every >= 1 and isinstance(detect_every, int)
                and detect_every >= 1 and isinstance(tracker_lost_after, int) and tracker_lost_after >= 1):
            raise ValueError("reseed_every, detect_every and tracker_lost_after must be whole numbers ≥ 1")
        if tracker is not None:
            tracker = str(tracker).strip().lower()
            if tracker in ("", "none", "off"):
                tracker = None
            elif tracker not in TRACKER_KINDS:
                raise ValueError(f"tracker = {tracker!r} is not one of {', '.join(TRACKER_KINDS)} (or None: no tracker)")
            else:
                from core.detect.tracking import available_trackers

                if tracker.upper() not in available_trackers():
                    raise ValueError(f"tracker {tracker} is not in this OpenCV build; available: "
                                     f"{', '.join(k.lower() for k in available_trackers())}")
        if detect_every > 1 and tracker is None:
            raise ValueError(f"detect_every = {detect_every} needs a tracker (tracker='kcf', …) for the frames "
                             "the detector skips")
        self.calibration = calibration
        # the marker perception's geometry (rectify points, triangulate, camera -> base); its
        # ArUco detectors are never run here
        self.geometry = StereoMarkerPerception(calibration, base_T_camera, marker_ids=())
        self.base_T_camera = self.geometry.base_T_camera
        self.detectors = list(detectors)
        self.max_dy_px = float(max_dy_px)
        self.min_disparity_px = float(min_disparity_px)
        self.size_ratio = float(size_ratio)
        self.compensate_skew = bool(compensate_skew)
        self.gate_m = float(gate_m)
        self.drop_after = int(drop_after)
        self.velocity_history = int(velocity_history)
        self.max_history_gap_s = float(max_history_gap_s)
        self.process_noise = float(process_noise)
        self.measurement_noise = float(measurement_noise)
        self.refine_centres = bool(refine_centres)  # blobs: sub-pixel centroid (``blob_centre``)
        self.min_hits = int(min_hits)
        self.desk_check = bool(desk_check)  # pairs whose point is below the desk or above the cameras: not objects
        self.min_z_m = float(min_z_m)
        self.max_z_m = None if max_z_m is None else float(max_z_m)  # None: the left camera's height
        self.merge_fragments = bool(merge_fragments)
        self.fuse_circles = bool(fuse_circles)  # a colour blob and an ellipse on it: one detection (``fuse_round_tops``)
        self.roi_search = bool(roi_search)
        self.full_frame_every = int(full_frame_every)
        self.roi_margin = float(roi_margin)
        self.tracker = tracker
        self.reseed_every = int(reseed_every)
        self.detect_every = int(detect_every)
        self.tracker_lost_after = int(tracker_lost_after)
        # None: alternate while every detector is a heavy one (a network per view; see alternating)
        self.alternate_views = None if alternate_views is None else bool(alternate_views)
        self.left_detect_every = int(left_detect_every)  # alternating: the left view's search every this many frames
        self.tracks: dict[int, _ObjectTrack] = {}  # confirmed tracks, by public id
        self.tentative: dict[int, _ObjectTrack] = {}  # tracks waiting for min_hits, by internal key
        self.lost: dict[int, tuple[_ObjectTrack, float]] = {}  # dropped tracks, by id: (track, time lost)
        self.frames = 0  # frames processed (repeated frames not counted)
        self.full_frame_searches = 0
        self.last_full_frame_search = True
        self.last_detector_run = True
        self.last_timings_ms: dict[str, float] = {}
        self._next_id = 1
        self._next_key = 1
        self._since_full = 0  # frames since the last full-frame search
        self._since_detect = 0  # frames since the detectors last ran
        self._since_left = 0  # alternating: frames since the left view was searched
        self._previous: Optional[tuple[float, np.ndarray]] = None  # the last frame's (t, left image)
        self.followed_frames = 0  # alternating: frames whose left boxes followed their patch (no search)
        self._t: Optional[float] = None
        self._last: Optional[tuple[StereoFrame, list[ObjectObservation]]] = None
        self._plain: set = set()  # id() of this frame's merged / tracker detections: no sub-pixel refinement
        self._from_tracker: set = set()  # id() of this frame's tracker detections
        # this frame's boxes predicted for the view not searched, by id() (held: their ids stay theirs)
        self._predicted: dict[int, Detection] = {}
        self._keep: list[Detection] = []  # detections made this frame whose ids the sets above hold
        self._placed: set = set()  # id() of boxes placed by a patch match: not a detector's whole blob (no extent)

    def reset(self) -> None:
        """Forget every track (ids start again at 1)."""
        self.tracks.clear()
        self.tentative.clear()
        self.lost.clear()
        self._next_id = 1
        self._next_key = 1
        self._since_full = self._since_detect = self._since_left = 0
        self._previous = None
        self._t = None
        self._last = None

    @property
    def max_z(self) -> float:
        """Highest plausible object point (robot_base z, m): ``max_z_m`` or the left camera's height."""
        return float(self.base_T_camera[2, 3]) if self.max_z_m is None else self.max_z_m

    def live_tracks(self) -> list[_ObjectTrack]:
        return list(self.tracks.values()) + list(self.tentative.values())

    # --- geometry -------------------------------------------------------------------------
    def _stereo_match_trackers(self, pairs, views: dict) -> None:
        """Re-place each paired view whose box came from its tracker (or was predicted) by finding
        the other view's patch of the object near it (``_place_by_match``; both from trackers: the
        right one is re-placed from the left). ``views``: side → (detections, image, rectified
        centres), updated in place."""
        left, right = views["left"][0], views["right"][0]
        for i, j, *_ in pairs:
            for moved, idx, source in (("right", j, left[i]), ("left", i, right[j])):
                if id(views[moved][0][idx]) in self._from_tracker:
                    predicted = id(views[moved][0][idx]) in self._predicted
                    guess = _centred_on(views[moved][0][idx], source) if predicted else None
                    self._place_by_match(views, moved, idx, source, refine=predicted, tracked=not predicted, guess=guess)
                    break

    def _place_by_match(self, views: dict, moved: str, idx: int, source: Detection, refine: bool = False,
                        max_shift_px: Optional[float] = None, tracked: bool = True,
                        guess: Optional[Detection] = None) -> bool:
        """Re-place ``views[moved]``'s detection ``idx`` (a tracker's or a predicted box) where
        ``source`` (the other view's detection of the object) finds its patch near it
        (``stereo_matched_centre``); False when it cannot (the detection stays). ``refine``: its
        centre is then the blob's sub-pixel centre in the placed box (``blob_centre``, as a
        detector's box gets: the patch match is biased by the background around the object),
        else the matched centre. Not when that would move it more than ``max_shift_px``.
        ``tracked``: the placed detection counts as a tracker's (``from_tracker``). ``guess``: where
        to search instead of around the detection itself (a box of ``source``'s size)."""
        other = "left" if moved == "right" else "right"
        dets, image, rect = views[moved]
        refined = self.refine_centres and id(source) not in self._plain
        source_centre = blob_centre(views[other][1], source) if refined else source.centre_px
        centre = stereo_matched_centre(views[other][1], source, image, dets[idx] if guess is None else guess,
                                       centre=source_centre)
        if centre is None:
            return False
        old = dets[idx]
        shift = (centre[0] - old.centre_px[0], centre[1] - old.centre_px[1])
        if max_shift_px is not None and math.hypot(*shift) > max_shift_px:
            return False
        new = replace(old, centre_px=centre, box=(old.box[0] + shift[0], old.box[1] + shift[1], old.box[2], old.box[3]))
        if refine and self.refine_centres:
            if source.contour is not None:  # the source's outline where the match put it, for blob_centre
                moved_by = np.array([centre[0] - source_centre[0], centre[1] - source_centre[1]])
                new = replace(new, contour=np.asarray(source.contour, float) + moved_by)
            centre = blob_centre(image, new)
        else:
            self._plain.add(id(new))
        if tracked:
            self._from_tracker.add(id(new))
        self._placed.add(id(new))
        self._keep.append(new)  # ids in the sets above stay this frame's
        dets[idx] = new
        rect[idx] = self.geometry.rectify_points(moved, np.array([centre], dtype=float))[0]
        return True

    def rectify(self, side: str, detections: Sequence[Detection], image: Optional[np.ndarray] = None) -> np.ndarray:
        """Rectified centres (N, 2) of raw-image detections in ``side`` (blobs refined sub-pixel
        in ``image`` when ``refine_centres``: see ``blob_centre``)."""
        if not detections:
            return np.zeros((0, 2))
        centres = [blob_centre(image, d) if self.refine_centres and id(d) not in self._plain else d.centre_px
                   for d in detections]
        return self.geometry.rectify_points(side, np.array(centres, dtype=float))

    def triangulate(self, rect_left: np.ndarray, rect_right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """camera_left and robot_base points (N, 3) of rectified centre pairs (N, 2) each."""
        cam = self.geometry.triangulate_rectified(np.asarray(rect_left, float).reshape(-1, 2),
                                                  np.asarray(rect_right, float).reshape(-1, 2))
        return cam, self.geometry.camera_to_base(cam)

    def project_rectified(self, side: str, base_p) -> np.ndarray:
        """Rectified pixel (2,) of a robot_base point in ``side`` (for single-view association)."""
        camera_p = np.linalg.solve(self.base_T_camera[:3, :3], np.asarray(base_p, float) - self.base_T_camera[:3, 3])
        rect = self.calibration.R1 @ camera_p  # rectified-left frame (both P1 and P2 use it)
        P = self.calibration.P1 if side == "left" else self.calibration.P2
        h = P @ np.append(rect, 1.0)
        return h[:2] / h[2]

    def plausible(self, base_p: np.ndarray) -> np.ndarray:
        """Which robot_base points (N, 3) can be objects: not below the desk plane (z < ``min_z_m``)
        nor above ``max_z`` (the cameras' height); all when ``desk_check`` is off."""
        base_p = np.asarray(base_p, float).reshape(-1, 3)
        if not self.desk_check:
            return np.ones(len(base_p), bool)
        z = base_p[:, 2]
        return np.isfinite(base_p).all(axis=1) & (z >= self.min_z_m) & (z <= self.max_z)

    # --- matching -------------------------------------------------------------------------
    def match(self, left: Sequence[Detection], right: Sequence[Detection],
              rect_left: np.ndarray, rect_right: np.ndarray) -> list[tuple[int, int, float]]:
        """Pairs (i_left, j_right, cost) of one-to-one matches, cheapest first (greedy).

        A pair needs the same kind and label, rows within ``max_dy_px``, a disparity of at least
        ``min_disparity_px``, radius and box sides within ``size_ratio`` (an object cut by the image
        border or hidden differently in the two views is not one pair) and, with ``desk_check``,
        a point that can be an object (``plausible``)."""
        log_ratio = math.log(self.size_ratio) if self.size_ratio > 1.0 else 1e-9
        candidates = []
        for i, dl in enumerate(left):
            for j, dr in enumerate(right):
                if dl.kind != dr.kind or dl.label != dr.label:
                    continue
                dy = abs(float(rect_left[i, 1] - rect_right[j, 1]))
                if dy > self.max_dy_px:
                    continue
                if float(rect_left[i, 0] - rect_right[j, 0]) < self.min_disparity_px:
                    continue
                ratio = abs(math.log(_size(dl) / _size(dr)))
                if ratio > log_ratio + 1e-12:
                    continue
                sides = [abs(math.log(max(a, 1.0) / max(b, 1.0))) for a, b in zip(dl.box[2:], dr.box[2:])]
                if max(sides) > log_ratio + 1e-12:
                    continue
                candidates.append((dy / self.max_dy_px + ratio / log_ratio, i, j))
        if candidates and self.desk_check:
            idx_l = [i for _, i, _ in candidates]
            idx_r = [j for _, _, j in candidates]
            _, base = self.triangulate(rect_left[idx_l], rect_right[idx_r])
            ok = self.plausible(base)
            candidates = [c for c, keep in zip(candidates, ok) if keep]
        candidates.sort()
        used_l, used_r, pairs = set(), set(), []
        for cost, i, j in candidates:
            if i in used_l or j in used_r:
                continue
            used_l.add(i)
            used_r.add(j)
            pairs.append((i, j, cost))
        return pairs

    # --- detection --------------------------------------------------------------------------
    def detect(self, image, roi=None) -> list[Detection]:
        """Every detector's detections in ``image`` (only inside ``roi`` = (x, y, w, h) when given)."""
        found: list[Detection] = []
        for detector in self.detectors:
            found.extend(detector.detect(image) if roi is None else detector.detect(image, roi))
        return found

    def search_windows(self, side: str, t: float, shape) -> list[tuple[int, int, int, int]]:
        """The ROI search's windows in ``side`` at ``t``: each live track's predicted box grown by
        ``roi_margin`` box sizes plus its image motion since it was last seen, overlaps merged."""
        boxes = []
        for track in self.live_tracks():
            pb = track.predicted_box(side, t)
            if pb is None:
                continue
            x, y, w, h = (float(v) for v in pb)
            vel = track.image_velocity(side)
            motion = 0.0
            if vel is not None:
                motion = float(np.hypot(*vel)) * max(t - track.view[side][0], 1.0 / 30.0)
            m = self.roi_margin * max(w, h) + motion + ROI_MIN_MARGIN_PX
            boxes.append([x - m, y - m, w + 2 * m, h + 2 * m])
        out = []
        for b in _merge_boxes(boxes):
            try:
                out.append(clip_roi(b, shape))
            except ValueError:
                continue  # predicted outside the image: the object left (the full search finds it back)
        return out

    def _detect_windows(self, image: np.ndarray, windows) -> tuple[list[Detection], bool]:
        """Detections inside ``windows``; True as well when one touches a window edge that is not
        the image's (cut off by the window: the frame needs a full search)."""
        H, W = image.shape[:2]
        found, cut = [], False
        for wx, wy, ww, wh in windows:
            for d in self.detect(image, (wx, wy, ww, wh)):
                x, y, w, h = d.box
                if ((wx > 0 and x <= wx + 1) or (wy > 0 and y <= wy + 1)
                        or (wx + ww < W and x + w >= wx + ww - 1) or (wy + wh < H and y + h >= wy + wh - 1)):
                    cut = True
                found.append(d)
        return found, cut

    def _merge_fragments(self, side: str, t: float, dets: list[Detection]) -> list[Detection]:
        """Per live track (oldest first): same-label blobs inside its predicted box whose union still
        fits its size (``MERGE_SLACK``) become one detection (``merge_detections``)."""
        counts = collections.Counter((d.kind, d.label) for d in dets if d.contour is not None)
        if not counts or max(counts.values()) < 2:
            return dets  # no label has two blobs here: nothing to merge (the usual frame)
        tracks = sorted(self.live_tracks(), key=lambda tr: (not tr.confirmed, -tr.frames))
        for track in tracks:
            if not track.extent[side] or counts[(track.kind, track.label)] < 2:
                continue
            pb = track.predicted_box(side, t)
            if pb is None:
                continue
            inside = [k for k, d in enumerate(dets)
                      if d.kind == track.kind and d.label == track.label and d.contour is not None
                      and _inside(d.centre_px, pb, MERGE_GROW)]
            if len(inside) < 2:
                continue
            parts = [dets[k] for k in inside]
            x0 = min(d.box[0] for d in parts)
            y0 = min(d.box[1] for d in parts)
            x1 = max(d.box[0] + d.box[2] for d in parts)
            y1 = max(d.box[1] + d.box[3] for d in parts)
            W, H = track.size(side)
            if x1 - x0 > MERGE_SLACK * W + MERGE_PAD_PX or y1 - y0 > MERGE_SLACK * H + MERGE_PAD_PX:
                continue  # together larger than the object: more than one object
            merged = merge_detections(parts)
            self._plain.add(id(merged))
            dets = [d for k, d in enumerate(dets) if k not in inside] + [merged]
        return dets

    def _track_views(self, side: str, image: np.ndarray, t: float, dets: Optional[list[Detection]]) -> list[Detection]:
        """Update each confirmed track's tracker in ``side``; where the detector missed the object
        (or did not run: ``dets`` None), the tracker's box joins the detections."""
        out = list(dets) if dets is not None else []
        for track in self.tracks.values():
            tracker = track.trackers[side]
            if tracker is None:
                continue
            same = None if dets is None else [d for d in dets if d.kind == track.kind and d.label == track.label]
            seen = tracker.match(same, t) if same else None
            if seen is not None:
                # the detector sees it: the tracker only notes the box (it runs again, re-seeded from
                # here, on the first frame the detector misses the object)
                try:
                    tracker.observe(image, t, seen.box)
                except ValueError:
                    pass  # a sliver at the image border: the tracker keeps its last box
                continue
            state = tracker.update(image, t, same)
            if not state.ok or state.lost:
                continue
            box = state.box
            if same and any(_inside(d.centre_px, box) or _inside(state.centre_px, d.box) for d in same):
                continue  # the detector sees it: its detection is better than the tracker's box
            radius = track.view[side][5] if track.view[side] is not None else 0.5 * math.hypot(box[2], box[3])
            d = Detection(kind=track.kind, label=track.label, score=0.5, box=box, centre_px=state.centre_px,
                          radius_px=radius)
            self._plain.add(id(d))
            self._from_tracker.add(id(d))
            out.append(d)
        return out

    def _start_trackers(self, track: _ObjectTrack, images: dict, times: dict, dets: dict) -> None:
        """Seed a confirmed track's missing trackers from this frame's detections of it."""
        from core.detect.tracking import ObjectTracker

        for side in SIDES:
            d = dets.get(side)
            if d is None or id(d) in self._from_tracker or track.trackers[side] is not None:
                continue
            tracker = ObjectTracker(self.tracker.upper(), reseed_every=self.reseed_every,
                                    lost_after=self.tracker_lost_after)
            try:
                tracker.start(images[side], d.box, times[side])
            except ValueError:
                continue  # a box at the image border too small to track
            track.trackers[side] = tracker

    # --- one frame ------------------------------------------------------------------------
    @property
    def alternating(self) -> bool:
        """Between full searches, the detectors run in one view a frame, left and right in turn
        (``alternate_views``; None: when every detector is heavy — a network a view — and neither
        trackers nor ROI search are on). The other view's boxes are the tracks' predicted boxes,
        placed by matching the searched view's patch of each object (``stereo_matched_centre``)."""
        if self.tracker is not None or self.roi_search:
            return False
        if self.alternate_views is not None:
            return self.alternate_views
        return bool(self.detectors) and all(getattr(d, "heavy", False) for d in self.detectors)

    def _predicted_view(self, side: str, t: float, searched: Sequence[Detection], t_searched: float) -> list[Detection]:
        """Each confirmed track's box in ``side`` at ``t`` as a stand-in detection (to be placed by
        ``_stereo_match_trackers``; dropped where it cannot be): where the searched view's detection
        of it (same label, nearest its predicted box there, each used once) lies, moved by the
        track's stereo offset — the disparity changes little from frame to frame, while a view's own
        motion prediction can be far off for a rolling ball or one back from behind the arm — else
        the track's predicted box in ``side``."""
        searched_side = "left" if side == "right" else "right"
        sign = 1.0 if side == "right" else -1.0
        candidates = []
        for track in self.tracks.values():
            if track.stereo_offset is None:
                continue
            box = track.predicted_box(searched_side, t_searched)
            if box is None:
                continue
            cx, cy = box[0] + box[2] / 2.0, box[1] + box[3] / 2.0
            gate = max(PREDICTED_VIEW_GATE_PX, 2.0 * max(float(box[2]), float(box[3])))
            for k, d in enumerate(searched):
                if d.label == track.label:
                    dist = math.hypot(d.centre_px[0] - cx, d.centre_px[1] - cy)
                    if dist <= gate:
                        candidates.append((dist, track.key, k))
        found: dict[int, Detection] = {}
        used = set()
        for _, key, k in sorted(candidates):
            if key not in found and k not in used:
                found[key] = searched[k]
                used.add(k)
        out = []
        for track in self.tracks.values():
            box = track.predicted_box(side, t)
            if box is None:
                continue
            x, y, w, h = (float(v) for v in box)
            source = found.get(track.key)
            if source is not None:  # the searched view's detection, moved by the stereo offset
                ox, oy = track.stereo_offset
                x = source.centre_px[0] + sign * ox - w / 2.0
                y = source.centre_px[1] + sign * oy - h / 2.0
            d = Detection(kind=track.kind, label=track.label, score=track.score, box=(x, y, w, h),
                          centre_px=(x + w / 2.0, y + h / 2.0), radius_px=track.view[side][5])
            self._plain.add(id(d))
            self._from_tracker.add(id(d))
            self._predicted[id(d)] = d
            out.append(d)
        return out

    def _followed_view(self, side: str, image: np.ndarray, t: float) -> Optional[list[Detection]]:
        """Each track measured on the last frame, its ``side`` box found again in ``image`` by its
        patch in that frame (``stereo_matched_centre`` around the box moved by its image velocity):
        the frames between the searches of an alternating heavy detector. None when the last frame
        is not at hand or a box's patch is not found (the view is then searched)."""
        if self._previous is None:
            return None
        t_prev, prev_image = self._previous
        if prev_image.shape != image.shape:
            return None
        out = []
        for track in self.tracks.values():
            v = track.view[side]
            if track.missed > 0 or v is None or v[0] != t_prev:
                continue  # not seen on the last frame: the next search looks for it
            _, x, y, w, h, radius = v
            template = Detection(kind=track.kind, label=track.label, score=track.score, box=(x, y, w, h),
                                 centre_px=(x + w / 2.0, y + h / 2.0), radius_px=radius)
            gx, gy = x, y
            vel = track.image_velocity(side)
            if vel is not None:
                dt = min(max(t - t_prev, 0.0), 0.5)
                gx, gy = x + float(vel[0]) * dt, y + float(vel[1]) * dt
            guess = replace(template, box=(gx, gy, w, h))
            centre = stereo_matched_centre(prev_image, template, image, guess)
            if centre is None:
                return None
            d = replace(template, box=(centre[0] - w / 2.0, centre[1] - h / 2.0, w, h), centre_px=centre)
            outline = track.outline[side]
            if outline is not None and self.refine_centres:  # a blob: its outline moved along, for blob_centre
                moved = np.asarray(outline, float) + np.array([centre[0] - template.centre_px[0],
                                                               centre[1] - template.centre_px[1]])
                d = replace(d, contour=moved)
            else:
                self._plain.add(id(d))
            self._placed.add(id(d))
            self._keep.append(d)
            out.append(d)
        return out

    def _search_mode(self) -> str:
        """"full", "roi", "one" (alternate views: the left searched), "follow" (alternate views:
        no search, the left boxes follow their patch) or "none" (trackers only) for the next frame."""
        unsettled = not self.tracks or bool(self.tentative) or any(tr.missed > 0 for tr in self.tracks.values())
        if (self.tracker is not None and self.detect_every > 1 and not unsettled
                and self._since_detect + 1 < self.detect_every):
            return "none"
        if self.alternating:  # both views while a track is new or just missed (ALTERNATE_MISSED_FULL frames)
            unsettled = (not self.tracks or bool(self.tentative)
                         or any(0 < tr.missed <= ALTERNATE_MISSED_FULL for tr in self.tracks.values()))
            if unsettled or self._since_full + 1 >= self.full_frame_every:
                return "full"
            return "follow" if self._since_left + 1 < self.left_detect_every else "one"
        if not self.roi_search or unsettled or self._since_full + 1 >= self.full_frame_every:
            return "full"
        return "roi"

    def process(self, frame: StereoFrame) -> list[ObjectObservation]:
        """Detect, match, triangulate and track the objects of one stereo frame."""
        w0 = time.perf_counter()
        last = self._last
        if (frame.repeated and last is not None and last[0].left is frame.left
                and last[0].right is frame.right):
            return list(last[1])
        t = float(frame.t)
        if self._t is not None and t < self._t:
            self.reset()  # time went backwards (a replay restarted): the tracks mean nothing now
        self._t = t
        self.frames += 1
        self._plain.clear()
        self._from_tracker.clear()
        self._predicted.clear()
        self._keep.clear()
        self._placed.clear()
        t_right = t + float(frame.skew_s)
        images = {"left": frame.left, "right": frame.right}
        times = {"left": t, "right": t_right}

        mode = self._search_mode()
        dets: dict[str, Optional[list[Detection]]] = {"left": None, "right": None}
        if mode == "roi":
            cut = False
            for side in SIDES:
                windows = self.search_windows(side, times[side], images[side].shape)
                dets[side], cut_here = self._detect_windows(images[side], windows)
                cut = cut or cut_here
            if cut:
                mode = "full"  # a blob cut by its window: this frame gets a full search after all
        if mode == "follow":
            dets["left"] = self._followed_view("left", frame.left, t)
            if dets["left"] is None:
                mode = "one"  # a box its patch did not find: the left view is searched after all
            else:
                dets["right"] = self._predicted_view("right", t_right, dets["left"], t)
                self.followed_frames += 1
        if mode == "one":
            searched, other = "left", "right"
            dets[searched] = self.detect(images[searched])
            dets[other] = self._predicted_view(other, times[other], dets[searched], times[searched])
        if mode == "full":
            dets = {side: self.detect(images[side]) for side in SIDES}
            self._since_full = 0
            self.full_frame_searches += 1
        else:
            self._since_full += 1
        self._since_detect = 0 if mode not in ("none", "follow") else self._since_detect + 1
        self._since_left = 0 if mode in ("one", "full") else self._since_left + 1
        self._previous = (t, frame.left)
        self.last_full_frame_search = mode == "full"
        self.last_detector_run = mode not in ("none", "follow")
        w1 = time.perf_counter()

        if self.fuse_circles:
            for side in SIDES:
                if dets[side]:
                    dets[side], fused = fuse_round_tops(dets[side])
                    self._plain.update(fused)
        if self.merge_fragments:
            for side in SIDES:
                if dets[side]:
                    dets[side] = self._merge_fragments(side, times[side], dets[side])
        if self.tracker is not None:
            views = {side: self._track_views(side, images[side], times[side], dets[side]) for side in SIDES}
        else:
            views = {side: dets[side] or [] for side in SIDES}
        w2 = time.perf_counter()
        left, right = views["left"], views["right"]
        rect_l = self.rectify("left", left, frame.left)
        rect_r = self.rectify("right", right, frame.right)
        pairs = self.match(left, right, rect_l, rect_r)
        placing = {"left": (left, frame.left, rect_l), "right": (right, frame.right, rect_r)}  # for _place_by_match
        if self._from_tracker and pairs:
            self._stereo_match_trackers(pairs, placing)
            if self._predicted:  # a predicted box the searched view's patch did not place: no pair
                pairs = [p for p in pairs if id(left[p[0]]) not in self._predicted and id(right[p[1]]) not in self._predicted]
        if mode == "full" and pairs and self.alternating:
            # a full search's right boxes are placed from the left patch too (when that moves them
            # little): measured as on the frames between, a box-only detector's objects do not
            # step in depth at every full search (their velocity would: 32 against 11 mm/s p50)
            for i, j, _ in pairs:
                self._place_by_match(placing, "right", j, left[i], refine=True, max_shift_px=FULL_PLACE_MAX_PX,
                                     tracked=False)

        out: list[ObjectObservation] = []
        assignment = self._associate(t, t_right, pairs, left, right, rect_l, rect_r) if pairs else []
        updated = set()
        for k, (i, j, _) in enumerate(pairs):
            track = assignment[k]
            if track is None:
                continue  # a fragment of an object measured this frame
            updated.add(track.key)
            obs = self._measure(track, t, t_right, frame.skew_s, left[i], right[j], rect_l[i], rect_r[j])
            track.note_view("left", t, left[i], id(left[i]) not in self._plain and id(left[i]) not in self._placed)
            track.note_view("right", t_right, right[j], id(right[j]) not in self._plain and id(right[j]) not in self._placed)
            track.stereo_offset = (right[j].centre_px[0] - left[i].centre_px[0], right[j].centre_px[1] - left[i].centre_px[1])
            if not track.confirmed and track.hits >= self.min_hits:
                self._confirm(track)
                obs = _with_id(obs, track.object_id)
            if track.confirmed:
                if self.tracker is not None:
                    self._start_trackers(track, images, times, {"left": left[i], "right": right[j]})
                out.append(obs)

        # tracked objects not triangulated: tentative ones end, confirmed ones are reported from
        # one view while they last
        used_l = {i for i, _, _ in pairs}
        used_r = {j for _, j, _ in pairs}
        for key in [k for k in self.tentative if k not in updated]:
            del self.tentative[key]
        for track in list(self.tracks.values()):
            if track.key in updated:
                continue
            track.missed += 1
            track.hits = 0
            if track.missed > self.drop_after:
                del self.tracks[track.object_id]
                track.trackers = {side: None for side in SIDES}
                self.lost[track.object_id] = (track, t)  # it may come back (re-enters the view)
                continue
            single = self._single_view(track, t, t_right, left, right, rect_l, rect_r, used_l, used_r)
            if single is not None:
                out.append(single)
        out.sort(key=lambda o: o.object_id)
        self._last = (frame, out)
        w3 = time.perf_counter()
        self.last_timings_ms = {"detect": (w1 - w0) * 1e3, "track": (w2 - w1) * 1e3,
                                "match": (w3 - w2) * 1e3, "total": (w3 - w0) * 1e3}
        return list(out)

    def _confirm(self, track: _ObjectTrack) -> None:
        """A tentative track seen ``min_hits`` frames in a row gets its public id."""
        self.tentative.pop(track.key, None)
        track.object_id = self._next_id
        self._next_id += 1
        self.tracks[track.object_id] = track

    def _covering(self, t: float, t_right: float, dl: Detection, dr: Detection) -> list[_ObjectTrack]:
        """Live tracks of this pair's label whose predicted centres lie inside both its boxes."""
        found = []
        for track in self.live_tracks():
            if track.kind != dl.kind or track.label != dl.label:
                continue
            pl, pr = track.predicted_box("left", t), track.predicted_box("right", t_right)
            if pl is None or pr is None:
                continue
            if _inside(pl[:2] + pl[2:] / 2, dl.box) and _inside(pr[:2] + pr[2:] / 2, dr.box):
                found.append(track)
        return found

    def _is_fragment(self, t: float, t_right: float, dl: Detection, dr: Detection, measured: list) -> bool:
        """Does this pair lie inside the predicted boxes (both views) of a track measured this frame?"""
        for track in measured:
            if track.kind != dl.kind or track.label != dl.label:
                continue
            pl, pr = track.predicted_box("left", t), track.predicted_box("right", t_right)
            if pl is None or pr is None:
                continue
            if _inside(dl.centre_px, pl, FRAGMENT_GROW) and _inside(dr.centre_px, pr, FRAGMENT_GROW):
                return True
        return False

    def _associate(self, t: float, t_right: float, pairs, left, right, rect_l, rect_r) -> list[Optional[_ObjectTrack]]:
        """The track of each matched pair: one blob covering several tracks of its label keeps the
        oldest; else the nearest prediction within the gate (confirmed tracks first); else a live
        or recently lost track near its last position; else, unless the pair is a fragment of an
        object measured this frame (None), a new tentative track."""
        idx_l = [i for i, _, _ in pairs]
        idx_r = [j for _, j, _ in pairs]
        _, base_p = self.triangulate(rect_l[idx_l], rect_r[idx_r])
        dets = [(left[i], right[j]) for i, j, _ in pairs]
        chosen: dict[int, _ObjectTrack] = {}
        taken = set()
        # one blob over several tracks of its label (a track started on a fragment, and its object
        # seen whole again): they are one object, the oldest track keeps it
        for k, (dl, dr) in enumerate(dets):
            covered = [tr for tr in self._covering(t, t_right, dl, dr) if tr.key not in taken]
            if len(covered) < 2:
                continue
            keeper = max(covered, key=lambda tr: (tr.confirmed, tr.frames, -tr.key))
            for tr in covered:
                if tr is not keeper:
                    self._forget(tr)
            chosen[k] = keeper
            taken.add(keeper.key)
        candidates = []
        for k, (dl, _) in enumerate(dets):
            if k in chosen:
                continue
            for track in self.live_tracks():
                if track.key in taken or track.kind != dl.kind or track.label != dl.label:
                    continue
                pred = track.predicted(t)
                if pred is None:
                    continue
                dist = float(np.linalg.norm(base_p[k] - pred))
                if dist < self.gate_m:
                    candidates.append((0 if track.confirmed else 1, dist, k, track.key))
        candidates.sort()
        by_key = {tr.key: tr for tr in self.live_tracks()}
        for _, dist, k, key in candidates:
            if k in chosen or key in taken:
                continue
            chosen[k] = by_key[key]
            taken.add(key)
        measured = list(chosen.values())
        result: list[Optional[_ObjectTrack]] = []
        for k, (dl, dr) in enumerate(dets):
            if k not in chosen:
                if self.merge_fragments and self._is_fragment(t, t_right, dl, dr, measured):
                    result.append(None)
                    continue
                # second chance before a new track: the same kind and label near where a live track
                # was last measured (it sped up past its prediction), else a recently lost one
                track = self._reacquire(t, dl, base_p[k], taken)
                if track is None:
                    track = _ObjectTrack(self._next_key, dl.kind, dl.label,
                                         ConstantVelocityKalman(self.process_noise, self.measurement_noise),
                                         self.velocity_history)
                    self._next_key += 1
                    if self.min_hits <= 1:
                        self._confirm(track)
                    else:
                        self.tentative[track.key] = track
                chosen[k] = track
                taken.add(track.key)
            result.append(chosen[k])
        return result

    def _forget(self, track: _ObjectTrack) -> None:
        """Drop a track for good (absorbed into another: not remembered as lost)."""
        if track.confirmed:
            self.tracks.pop(track.object_id, None)
        else:
            self.tentative.pop(track.key, None)

    def _reacquire(self, t: float, d: Detection, p: np.ndarray, taken: set) -> Optional[_ObjectTrack]:
        """A confirmed track of this label within ``REACQUIRE_M`` of its last position, or one lost in
        the last ``LOST_KEEP_S`` — the nearest; None when there is none."""
        best = _nearest_of_label(self.tracks.values(), d, p, taken, REACQUIRE_M)
        if best is not None:
            return best
        for object_id, (track, t_lost) in list(self.lost.items()):
            if t - t_lost > LOST_KEEP_S:
                del self.lost[object_id]
        best = _nearest_of_label((track for track, _ in self.lost.values()), d, p, taken, LOST_REACQUIRE_M)
        if best is not None:
            del self.lost[best.object_id]
            best.missed = 0
            best.hits = 0
            best.left_hist.clear()
            best.right_hist.clear()
            best.kf.reset()  # a fresh start where it came back
            self.tracks[best.object_id] = best
        return best

    def _measure(self, track: _ObjectTrack, t: float, t_right: float, skew_s: float,
                 dl: Detection, dr: Detection, rl: np.ndarray, rr: np.ndarray) -> ObjectObservation:
        """Triangulate one matched pair for ``track`` (skew-compensated when possible) and update it."""
        # a gap in the track makes its stored centres stale: start the image velocities afresh
        for hist, t_now in ((track.left_hist, t), (track.right_hist, t_right)):
            if hist and t_now - hist[-1][0] > self.max_history_gap_s:
                hist.clear()
        pl, pr = (float(rl[0]), float(rl[1])), (float(rr[0]), float(rr[1]))
        compensated = False
        if self.compensate_skew and skew_s != 0.0:
            v_l, v_r = track.velocities()
            if v_r is not None:
                pl, pr = compensate_pair(pl, v_l, t, pr, v_r, t_right, t_common=t)
                compensated = True
        camera_p, base_p = self.triangulate(np.array([pl]), np.array([pr]))
        resets = track.kf.resets
        _, v = track.kf.update(t, base_p[0])
        if track.kf.resets != resets:  # the Kalman restarted on a jump: so do the image velocities
            track.left_hist.clear()
            track.right_hist.clear()
        track.left_hist.append((t, float(rl[0]), float(rl[1])))
        track.right_hist.append((t_right, float(rr[0]), float(rr[1])))
        track.missed = 0
        track.frames += 1
        track.hits += 1
        return ObjectObservation(
            object_id=-1 if track.object_id is None else track.object_id, kind=dl.kind, label=dl.label,
            score=min(dl.score, dr.score),
            left=dl, right=dr, camera_p=_point(camera_p[0]), base_p=_point(base_p[0]),
            velocity_base=None if track.frames < 2 or v is None else _point(v),
            epipolar_dy_px=float(rl[1] - rr[1]), seen_left=True, seen_right=True, triangulated=True,
            disparity_px=float(pl[0] - pr[0]), skew_compensated=compensated, frames_tracked=track.frames,
            from_tracker=id(dl) in self._from_tracker or id(dr) in self._from_tracker,
        )

    def _single_view(self, track: _ObjectTrack, t: float, t_right: float, left, right, rect_l, rect_r,
                     used_l: set, used_r: set) -> Optional[ObjectObservation]:
        """The track's object when one view still sees it near the predicted position."""
        pred = track.predicted(t)
        if pred is None:
            return None
        for side, dets, rect, used, t_side in (("left", left, rect_l, used_l, t), ("right", right, rect_r, used_r, t_right)):
            expected = self.project_rectified(side, pred)
            best, best_d = None, None
            for i, d in enumerate(dets):
                if i in used or d.kind != track.kind or d.label != track.label:
                    continue
                dist = float(np.linalg.norm(rect[i] - expected))
                if dist <= max(15.0, 1.5 * _size(d)) and (best_d is None or dist < best_d):
                    best, best_d = i, dist
            if best is not None:
                used.add(best)
                d = dets[best]
                track.note_view(side, t_side, d, False)
                camera_p = np.linalg.solve(self.base_T_camera[:3, :3], pred - self.base_T_camera[:3, 3])
                v = track.kf.velocity
                return ObjectObservation(
                    object_id=track.object_id, kind=d.kind, label=d.label, score=d.score,
                    left=d if side == "left" else None, right=d if side == "right" else None,
                    camera_p=_point(camera_p), base_p=_point(pred),
                    velocity_base=None if track.frames < 2 or v is None else _point(v),
                    epipolar_dy_px=None, seen_left=side == "left", seen_right=side == "right",
                    triangulated=False, frames_tracked=track.frames,
                    from_tracker=id(d) in self._from_tracker,
                )
        return None


def _with_id(obs: ObjectObservation, object_id: int) -> ObjectObservation:
    return replace(obs, object_id=object_id)
