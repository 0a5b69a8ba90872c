"""Follow one object between detections with an OpenCV tracker, and know when it is gone.

``ObjectTracker`` is started from a box (a detection's, or one the user drew) and updated with
every image. The OpenCV tracker runs on a window cropped around where the object is predicted
to be (its last box moved by its image velocity, grown by ``search_margin`` box sizes on each
side), always of the same size, so the tracker sees the object near the same place of its
window and the cost does not grow with the image.

Detections keep it honest. A detection matching the tracked box (the best overlap, or the
nearest centre within the search window) re-seeds the tracker every ``reseed_every`` frames,
and at once when the tracker's box drifted off it (IoU < ``DRIFT_IOU``). Every update that came
with detections (a detector ran) is a re-seed opportunity: ``lost_after`` opportunities in a
row without a matching detection and the object is reported lost.

Between detections an appearance check guards against the classic tracker failure of locking
onto the desk where the object was: at every seed the tracker keeps the colour histogram and
edge density of the object's patch and of a ring of background around it; a patch that has
become more like that background than like the object (or a tracker that says it failed) is
not reported ``ok``, and a background-like patch is reported ``lost`` at once. A lost object
comes back only through a matching detection.

Cheap while the detector sees the object (``observe``): a caller that already knows the
object's box in this image (its detection) hands it over instead of calling ``update``. The
OpenCV tracker is then not run at all (an update costs ~1 ms on a small window and ~10 ms on a
plush-sized one under load); the box and time are kept, and the tracker is re-seeded from that
image and box only when it is next needed (the first ``update`` after the detector missed).

OpenCV 5 trackers (TECH_NOTES): KCF, CSRT, MIL in ``cv2``; MOSSE (and MedianFlow, Boosting, TLD)
under ``cv2.legacy``. ``available_trackers()`` lists those this build has.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import cv2
import numpy as np

DRIFT_IOU = 0.3  # a tracker box overlapping its detection less than this has drifted: re-seed now
MATCH_IOU = 0.1  # a detection overlapping the tracked box this much matches it
BACKGROUND_RING = 0.5  # the background ring around a seeded box is this many box sizes wide
# OpenCV 5's KCF only trains on its first update after init and returns the init box whatever
# the image shows: the object's first motion became a permanent offset (5 px here). One update on
# the seed image itself takes that step.
WARM_UP = ("KCF",)
APPEARANCE_MIN_DIST = 0.35  # a patch this close (Bhattacharyya) to the seeded object is the object
# OpenCV's legacy MOSSE learns its filter on the init box itself, with no padding, and reports a
# failure whenever the peak-to-sidelobe ratio of its response is below a fixed 5.7. A plain ball
# fills that box with one colour: the response is flat and every update failed (59 of 59 frames
# of the bench's red ball). Markers, which the original desk tracked with it, are full of edges.
# Given the object with a ring of desk around it, the filter sees the object's outline: 0 of 59
# failed, centre error 0.39 px median (2x); 1.5x and 2.5x did as well, 3x drifted (1.6 px).
CONTEXT_PAD = {"MOSSE": 2.0}  # kind -> the box the tracker is given, in object box sizes

_FACTORIES = {  # kind -> (module path, factory name)
    "KCF": ("", "TrackerKCF_create"),
    "CSRT": ("", "TrackerCSRT_create"),
    "MIL": ("", "TrackerMIL_create"),
    "MOSSE": ("legacy", "TrackerMOSSE_create"),
    "MEDIANFLOW": ("legacy", "TrackerMedianFlow_create"),
    "BOOSTING": ("legacy", "TrackerBoosting_create"),
    "TLD": ("legacy", "TrackerTLD_create"),
}


def _factory(kind: str):
    where, name = _FACTORIES[kind]
    module = getattr(cv2, where, None) if where else cv2
    return getattr(module, name, None) if module is not None else None


def available_trackers() -> list[str]:
    """The tracker kinds this OpenCV build can create (e.g. KCF, CSRT, MIL, MOSSE, …)."""
    return [kind for kind in _FACTORIES if _factory(kind) is not None]


@dataclass(frozen=True)
class TrackState:
    """The tracked object after one image."""

    box: tuple[float, float, float, float]  # x, y, w, h (px, full image); the last good box when lost
    centre_px: tuple[float, float]
    ok: bool  # the object is where ``box`` says in this image
    lost: bool  # the object is gone (left, hidden, or the tracker lost it): only a detection revives it
    velocity_px_s: tuple[float, float]  # image velocity of the centre (px/s)
    reseeded: bool  # this update re-seeded the tracker from a detection
    t: float = 0.0  # the image's time (s)


def iou(a, b) -> float:
    """Intersection over union of two (x, y, w, h) boxes."""
    ax, ay, aw, ah = (float(v) for v in a)
    bx, by, bw, bh = (float(v) for v in b)
    iw = min(ax + aw, bx + bw) - max(ax, bx)
    ih = min(ay + ah, by + bh) - max(ay, by)
    if iw <= 0 or ih <= 0:
        return 0.0
    inter = iw * ih
    return inter / (aw * ah + bw * bh - inter)


def _centre(box) -> np.ndarray:
    x, y, w, h = box
    return np.array([x + w / 2.0, y + h / 2.0])


def _clip_box(box, size) -> Optional[tuple[int, int, int, int]]:
    """Integer box inside an image of ``size`` (w, h), or None when nothing of it is inside."""
    W, H = size
    x0, y0 = int(np.floor(box[0])), int(np.floor(box[1]))
    x1, y1 = int(np.ceil(box[0] + box[2])), int(np.ceil(box[1] + box[3]))
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    return x0, y0, x1 - x0, y1 - y0


class _Appearance:
    """Colour histogram (HSV hue × saturation, plus value for greys) and edge density of a region."""

    BINS = (18, 8, 8)

    def __init__(self, hist: np.ndarray, edges: float):
        self.hist, self.edges = hist, edges

    @classmethod
    def of(cls, image: np.ndarray, box, mask: Optional[np.ndarray] = None) -> Optional["_Appearance"]:
        b = _clip_box(box, (image.shape[1], image.shape[0]))
        if b is None:
            return None
        x, y, w, h = b
        patch = image[y:y + h, x:x + w]
        m = None if mask is None else mask[y:y + h, x:x + w]
        if m is not None and cv2.countNonZero(m) < 8:
            return None
        hsv = cv2.cvtColor(patch, cv2.COLOR_BGR2HSV)
        hist = cv2.calcHist([hsv], [0, 1, 2], m, list(cls.BINS), [0, 180, 0, 256, 0, 256])
        cv2.normalize(hist, hist, 1.0, 0.0, cv2.NORM_L1)
        grey = cv2.cvtColor(patch, cv2.COLOR_BGR2GRAY)
        edges = cv2.Canny(grey, 60, 150)
        if m is not None:
            edges = cv2.bitwise_and(edges, m)
            n = max(cv2.countNonZero(m), 1)
        else:
            n = edges.size
        return cls(hist, cv2.countNonZero(edges) / n)

    def distance(self, other: "_Appearance") -> float:
        """0 (alike) … 1: colour Bhattacharyya distance, 80 %, and edge density difference, 20 %."""
        colour = cv2.compareHist(self.hist, other.hist, cv2.HISTCMP_BHATTACHARYYA)
        hi = max(self.edges, other.edges)
        edge = 0.0 if hi < 1e-3 else abs(self.edges - other.edges) / hi
        return 0.8 * float(colour) + 0.2 * edge


class ObjectTracker:
    """One object followed by an OpenCV tracker, re-seeded and checked by detections.

    ``start(image_bgr, box, t)`` seeds it; ``update(image_bgr, t, detections)`` returns a
    TrackState. ``detections``: None when no detector ran on this image, else the detections of
    this image (objects with ``.box`` (x, y, w, h), e.g. ``core.detect.base.Detection``; an
    empty list means the detector ran and saw nothing).
    """

    def __init__(self, kind: str = "KCF", reseed_every: int = 15, search_margin: float = 1.5,
                 lost_after: int = 5):
        kind = kind.upper()
        if kind not in _FACTORIES:
            raise ValueError(f"unknown tracker {kind!r}; known: {', '.join(_FACTORIES)}")
        if _factory(kind) is None:
            raise ValueError(f"tracker {kind} is not in this OpenCV build; available: "
                             f"{', '.join(available_trackers())}")
        if reseed_every < 1 or lost_after < 1 or not (0.25 <= search_margin <= 10):
            raise ValueError("reseed_every and lost_after must be ≥ 1 and search_margin in 0.25…10")
        self.kind = kind
        self.legacy = _FACTORIES[kind][0] == "legacy"
        self.reseed_every = int(reseed_every)
        self.search_margin = float(search_margin)
        self.lost_after = int(lost_after)
        self._tracker = None
        self._window: Optional[tuple[int, int, int, int]] = None  # crop the tracker saw last (x, y, w, h)
        self._box: Optional[np.ndarray] = None  # x, y, w, h (float, full image)
        self._t: Optional[float] = None
        self._velocity = np.zeros(2)
        self._frames_since_seed = 0
        self._unconfirmed = 0  # re-seed opportunities in a row without a matching detection
        self._lost = False
        self._failures = 0  # tracker failures in a row
        self._obj_look: Optional[_Appearance] = None
        self._bg_look: Optional[_Appearance] = None
        self._pending_seed: Optional[tuple] = None  # (image, box) to seed from before the next tracker run
        self.reseeds = 0
        self.state: Optional[TrackState] = None

    # -- seeding ---------------------------------------------------------------------------

    @property
    def started(self) -> bool:
        return self._box is not None

    @property
    def lost(self) -> bool:
        return self._lost

    def start(self, image_bgr: np.ndarray, box, t: float = 0.0) -> TrackState:
        """Seed on ``box`` (x, y, w, h) of ``image_bgr`` at time ``t``; velocity starts at zero."""
        self._velocity = np.zeros(2)
        self._t = float(t)
        self._pending_seed = None
        self._seed(image_bgr, box)
        self._unconfirmed = 0
        self.state = self._state(True, False)
        return self.state

    def observe(self, image_bgr: np.ndarray, t: float, box) -> TrackState:
        """The object is at ``box`` (x, y, w, h) in ``image_bgr`` at ``t`` (a detection of it): keep
        that without running the OpenCV tracker.

        Counts as a confirmed sighting (a lost object is back). The tracker is re-seeded from this
        image and box lazily, at the next ``update`` (so a run of frames where the detector sees
        the object costs no tracker updates and no appearance checks)."""
        if self._box is None:
            return self.start(image_bgr, box, t)
        b = np.asarray(box, dtype=float).reshape(4)
        size = (image_bgr.shape[1], image_bgr.shape[0])
        if b[2] < 2 or b[3] < 2 or _clip_box(b, size) is None:
            raise ValueError(f"box {tuple(b)} is empty or outside the {size[0]}x{size[1]} image")
        t = float(t)
        if self._t is not None and t - self._t > 1e-6 and not self._lost:
            measured = (_centre(b) - _centre(self._box)) / (t - self._t)
            self._velocity = 0.5 * self._velocity + 0.5 * measured
        elif self._lost:
            self._velocity = np.zeros(2)
        self._box, self._t = b, t
        self._pending_seed = (image_bgr, b)
        self._unconfirmed = 0
        self._failures = 0
        self._lost = False
        self.state = self._state(True, False, False, t)
        return self.state

    def match(self, detections: Sequence, t: float):
        """The detection among ``detections`` that is this object at ``t`` (the best overlap with
        its predicted box, else the nearest centre within the search window), or None."""
        if self._box is None:
            return None
        dt = max(float(t) - self._t, 0.0) if self._t is not None else 0.0
        predicted = self._box + np.array([*(self._velocity * dt), 0, 0])
        return self._match(predicted, detections, dt)

    def _seed(self, image: np.ndarray, box) -> None:
        size = (image.shape[1], image.shape[0])
        b = np.asarray(box, dtype=float).reshape(4)
        if b[2] < 2 or b[3] < 2 or _clip_box(b, size) is None:
            raise ValueError(f"box {tuple(b)} is empty or outside the {size[0]}x{size[1]} image")
        self._box = b
        self._window = self._window_around(b, size)
        wx, wy, _, _ = self._window
        crop = image[wy:wy + self._window[3], wx:wx + self._window[2]]
        local = self._padded((b[0] - wx, b[1] - wy, b[2], b[3]), CONTEXT_PAD.get(self.kind, 1.0))
        self._tracker = _factory(self.kind)()
        if self.legacy:
            self._tracker.init(crop, tuple(float(v) for v in local))
        else:
            self._tracker.init(crop, tuple(int(round(v)) for v in local))
        if self.kind in WARM_UP:
            self._tracker.update(crop)
        self._obj_look = _Appearance.of(image, self._inner(b))
        ring = BACKGROUND_RING
        outer = (b[0] - ring * b[2], b[1] - ring * b[3], b[2] * (1 + 2 * ring), b[3] * (1 + 2 * ring))
        mask = np.zeros(image.shape[:2], np.uint8)
        ob = _clip_box(outer, size)
        if ob is not None:
            mask[ob[1]:ob[1] + ob[3], ob[0]:ob[0] + ob[2]] = 255
        ib = _clip_box(b, size)
        mask[ib[1]:ib[1] + ib[3], ib[0]:ib[0] + ib[2]] = 0
        self._bg_look = _Appearance.of(image, outer, mask) if ob is not None else None
        self._frames_since_seed = 0
        self._lost = False

    @staticmethod
    def _inner(box) -> tuple:
        """The middle 80 % of a box: what surely is the object."""
        x, y, w, h = box
        return (x + 0.1 * w, y + 0.1 * h, 0.8 * w, 0.8 * h)

    def _window_around(self, box, size) -> tuple[int, int, int, int]:
        """The crop for a box: grown by search_margin box sizes on each side, moved inside the image."""
        W, H = size
        m = self.search_margin
        ww = min(W, int(np.ceil(box[2] * (1 + 2 * m))))
        wh = min(H, int(np.ceil(box[3] * (1 + 2 * m))))
        cx, cy = _centre(box)
        x = int(round(cx - ww / 2.0))
        y = int(round(cy - wh / 2.0))
        return min(max(x, 0), W - ww), min(max(y, 0), H - wh), ww, wh

    # -- tracking --------------------------------------------------------------------------

    def update(self, image_bgr: np.ndarray, t: float, detections: Optional[Sequence] = None) -> TrackState:
        if self._box is None:
            raise RuntimeError("ObjectTracker.update before start")
        t = float(t)
        dt = max(t - self._t, 1e-6) if self._t is not None else 0.0
        size = (image_bgr.shape[1], image_bgr.shape[0])
        if self._pending_seed is not None:  # observed by detections since the tracker last ran
            seed_image, seed_box = self._pending_seed
            self._pending_seed = None
            self._seed(seed_image, seed_box)
            self.reseeds += 1
        self._frames_since_seed += 1
        old_centre = _centre(self._box)

        tracked_ok, box = False, None
        if not self._lost:
            tracked_ok, box = self._track(image_bgr, dt, size)

        reseeded = False
        if detections is not None:
            reference = box if box is not None else self._box
            match = self._match(reference, detections, dt)
            if match is None:
                self._unconfirmed += 1
            else:
                self._unconfirmed = 0
                det_box = np.asarray(match.box, dtype=float).reshape(4)
                drifted = box is None or not tracked_ok or iou(box, det_box) < DRIFT_IOU
                if self._lost or drifted or self._frames_since_seed >= self.reseed_every:
                    self._seed(image_bgr, det_box)
                    self.reseeds += 1
                    reseeded, tracked_ok, box = True, True, det_box

        if box is None:
            box = self._box + np.array([*(self._velocity * dt), 0, 0])  # coast on the prediction
        ok = tracked_ok
        if not self._lost and not reseeded:
            # where the tracker put it (or, when the tracker failed, where it should be): still
            # the object, or the desk it stood on?
            self._failures = 0 if tracked_ok else self._failures + 1
            look = _Appearance.of(image_bgr, self._inner(box))
            if look is None:  # left the image
                ok, self._lost = False, True
            elif self._obj_look is not None:
                d_obj = look.distance(self._obj_look)
                d_bg = look.distance(self._bg_look) if self._bg_look is not None else 1.0
                if d_obj > APPEARANCE_MIN_DIST and d_bg < d_obj:
                    ok, self._lost = False, True  # the desk where the object was
            if self._failures >= self.lost_after:
                self._lost = True
        if reseeded:
            self._failures = 0
        if self._unconfirmed >= self.lost_after:
            self._lost = True
        if self._lost and not reseeded:
            ok = False
        if ok:
            centre = _centre(box)
            if dt > 0:
                measured = (centre - old_centre) / dt
                a = 1.0 if reseeded and self.state is not None and self.state.lost else 0.5
                self._velocity = (1 - a) * self._velocity + a * measured
            self._box = np.asarray(box, dtype=float)
        elif self._lost:
            self._velocity = np.zeros(2)
        else:
            self._box = np.asarray(box, dtype=float)  # coasting: predicted, not seen
        self._t = t
        self.state = self._state(ok, self._lost, reseeded, t)
        return self.state

    def _track(self, image: np.ndarray, dt: float, size):
        """Run the OpenCV tracker on the window around the predicted box: (ok, box in the image)."""
        predicted = self._box + np.array([*(self._velocity * dt), 0, 0])
        win = self._window_around(predicted, size)
        if win[2] != self._window[2] or win[3] != self._window[3]:
            # the tracker keeps its window size (it was seeded on one that size); only at image
            # borders can it differ — then keep the old size, shifted
            W, H = size
            win = (min(max(win[0], 0), W - self._window[2]), min(max(win[1], 0), H - self._window[3]),
                   self._window[2], self._window[3])
        x, y, w, h = win
        crop = image[y:y + h, x:x + w]
        # the tracker remembers the box in the previous window: its own search starts there, so
        # the new window is placed to make that spot the predicted position
        ok, local = self._tracker.update(crop)
        self._window = win
        if not ok:
            return False, None
        local = self._padded(local, 1.0 / CONTEXT_PAD.get(self.kind, 1.0))  # the object inside the context
        box = np.array([local[0] + x, local[1] + y, local[2], local[3]], dtype=float)
        return True, box

    @staticmethod
    def _padded(box, factor: float) -> tuple:
        """``box`` scaled by ``factor`` about its centre (x, y, w, h)."""
        if factor == 1.0:
            return tuple(box)
        x, y, w, h = (float(v) for v in box)
        return (x + w / 2.0 - factor * w / 2.0, y + h / 2.0 - factor * h / 2.0, factor * w, factor * h)

    def _match(self, reference, detections: Sequence, dt: float):
        """The detection of this object: the best overlap, else the nearest centre within the window."""
        best, best_iou = None, MATCH_IOU
        for det in detections:
            v = iou(reference, det.box)
            if v > best_iou:
                best, best_iou = det, v
        if best is not None:
            return best
        gate = 0.5 * (reference[2] + reference[3]) * self.search_margin
        c = _centre(reference) + (self._velocity * dt if self._lost else 0.0)
        best_d = gate
        for det in detections:
            d = float(np.linalg.norm(_centre(det.box) - c))
            if d < best_d:
                best, best_d = det, d
        return best

    def _state(self, ok: bool, lost: bool, reseeded: bool = False, t: Optional[float] = None) -> TrackState:
        b = self._box
        c = _centre(b)
        return TrackState(box=tuple(float(v) for v in b), centre_px=(float(c[0]), float(c[1])), ok=ok, lost=lost,
                          velocity_px_s=(float(self._velocity[0]), float(self._velocity[1])),
                          reseeded=reseeded, t=self._t if t is None else t)
