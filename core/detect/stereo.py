"""Any detected object located in 3D: match detections across a stereo pair, triangulate, track.

``StereoObjectPerception`` runs its detectors on both views of a ``StereoFrame``; detections of
the same kind and label whose rectified centres lie on the same row (epipolar consistency, within
``max_dy_px``), with a positive disparity and a similar size, are paired (greedily, cheapest
first: row offset plus size mismatch). Each pair's rectified centres are triangulated into
camera_left and mapped to robot_base with the calibration's rectification, exactly as the
marker perception does (``StereoMarkerPerception.rectify_points`` / ``triangulate_rectified`` /
``camera_to_base``: point-wise ``cv2.undistortPoints``, no remapped images).

Objects keep an id over time: each 3D point is associated with the live track of the same kind
and label whose constant-velocity Kalman prediction is nearest (within ``gate_m``); a point
with none gets a new id, and a track unseen for ``drop_after`` frames is forgotten.

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
from dataclasses import dataclass
from typing import Optional, Sequence

import cv2
import numpy as np

from core.detect.base import Detection, Detector
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


def _size(d: Detection) -> float:
    """A detection's size (px): its radius when it has one, else half the box's geometric mean side."""
    if d.radius_px is not None and d.radius_px > 0:
        return float(d.radius_px)
    w, h = d.box[2], d.box[3]
    return max(0.5, 0.5 * math.sqrt(max(w, 0.0) * max(h, 0.0)))


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
    lo = pts.min(axis=0) - pad
    hi = pts.max(axis=0) + pad + 1
    if (hi - lo).prod() > 4_000_000:  # a huge blob: the outline centroid is plenty
        return d.centre_px
    mask = np.zeros((int(hi[1] - lo[1]), int(hi[0] - lo[0])), np.uint8)
    cv2.drawContours(mask, [(pts - lo).reshape(-1, 1, 2)], 0, 255, -1)
    m = cv2.moments(mask, binaryImage=True)
    if m["m00"] <= 0:
        return d.centre_px
    area_centre = (float(lo[0] + m["m10"] / m["m00"]), float(lo[1] + m["m01"] / m["m00"]))
    if image is None or image.ndim != 3:
        return area_centre
    H, W = image.shape[:2]
    if lo[0] < 0 or lo[1] < 0 or hi[0] > W or hi[1] > H:
        return area_centre  # at the image border: the ring is cut off
    patch = image[lo[1]:hi[1], lo[0]:hi[0]].astype(np.float32)
    k3 = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))
    inner = cv2.erode(mask, k3, iterations=2)
    near = cv2.dilate(mask, k3, iterations=grow_px)
    ring = cv2.dilate(mask, k3, iterations=grow_px + 3) & ~cv2.dilate(mask, k3, iterations=grow_px + 1)
    if cv2.countNonZero(inner) < 8 or cv2.countNonZero(ring) < 8:
        return area_centre
    fg = patch[inner > 0].mean(axis=0)
    bg = patch[ring > 0].mean(axis=0)
    span = fg - bg
    n2 = float(span @ span)
    if n2 < 20.0 ** 2:
        return area_centre
    w = np.clip(((patch - bg) @ span) / n2, 0.0, 1.0)
    w[near == 0] = 0.0
    w[inner > 0] = 1.0
    total = float(w.sum())
    if total <= 0:
        return area_centre
    ys, xs = np.mgrid[0:w.shape[0], 0:w.shape[1]]
    return (float(lo[0] + (w * xs).sum() / total), float(lo[1] + (w * ys).sum() / total))


def _point(p) -> tuple[float, float, float]:
    return tuple(float(v) for v in np.asarray(p, dtype=float).reshape(3))


REACQUIRE_M = 0.20  # a live track's last position this near takes a detection its prediction missed
LOST_KEEP_S = 8.0  # a lost track is remembered this long, for an object that leaves and comes back
LOST_REACQUIRE_M = 0.40  # … and takes a detection of its label this near its last position


class _ObjectTrack:
    """What the perception remembers about one object between frames."""

    def __init__(self, object_id: int, kind: str, label: str, kalman: ConstantVelocityKalman, history: int):
        self.object_id = object_id
        self.kind, self.label = kind, label
        self.kf = kalman
        self.missed = 0  # frames in a row without a triangulated measurement
        self.frames = 0  # triangulated frames
        # rectified centres as seen, with their capture times: (t, x, y)
        self.left_hist: collections.deque = collections.deque(maxlen=history)
        self.right_hist: collections.deque = collections.deque(maxlen=history)

    def predicted(self, t: float) -> Optional[np.ndarray]:
        p, v = self.kf.position, self.kf.velocity
        if p is None:
            return None
        return p + v * max(0.0, t - self.kf.t)

    @staticmethod
    def _velocity(hist) -> Optional[np.ndarray]:
        """Image velocity (px/s): least-squares slope of the stored centres against time."""
        if len(hist) < 2:
            return None
        a = np.asarray(hist, dtype=float)
        t = a[:, 0] - a[:, 0].mean()
        den = float(t @ t)
        if den <= 1e-12:
            return None
        xy = a[:, 1:] - a[:, 1:].mean(axis=0)
        return (t @ xy) / den

    def velocities(self):
        return self._velocity(self.left_hist), self._velocity(self.right_hist)


class StereoObjectPerception:
    """Detections of any ``Detector`` in both views → matched pairs → robot_base points with ids.

    ``base_T_camera`` is the 4x4 pose of camera_left in robot_base. ``detectors`` each run on
    both raw views. Not thread-safe: one per worker.
    """

    def __init__(self, calibration: StereoCalibration, base_T_camera, detectors: Sequence[Detector],
                 max_dy_px: float = 4.0, min_disparity_px: float = 1.0, size_ratio: float = 1.6,
                 compensate_skew: bool = True, gate_m: float = 0.08, drop_after: int = 10,
                 velocity_history: int = 5, max_history_gap_s: float = 0.25,
                 process_noise: float = 0.5, measurement_noise: float = 0.002, refine_centres: bool = True):
        if not (max_dy_px > 0 and min_disparity_px >= 0 and size_ratio >= 1.0 and gate_m > 0):
            raise ValueError("max_dy_px and gate_m must be > 0, min_disparity_px ≥ 0 and size_ratio ≥ 1")
        if drop_after < 1 or velocity_history < 2:
            raise ValueError("drop_after must be ≥ 1 and velocity_history ≥ 2")
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
        self.tracks: dict[int, _ObjectTrack] = {}
        self.lost: dict[int, tuple[_ObjectTrack, float]] = {}  # dropped tracks, by id: (track, time lost)
        self._next_id = 1
        self._t: Optional[float] = None
        self._last: Optional[tuple[StereoFrame, list[ObjectObservation]]] = None

    def reset(self) -> None:
        """Forget every track (ids start again at 1)."""
        self.tracks.clear()
        self.lost.clear()
        self._next_id = 1
        self._t = None
        self._last = None

    # --- geometry -------------------------------------------------------------------------
    def rectify(self, side: str, detections: Sequence[Detection], image: Optional[np.ndarray] = None) -> np.ndarray:
        """Rectified centres (N, 2) of raw-image detections in ``side`` (blobs refined sub-pixel
        in ``image`` when ``refine_centres``: see ``blob_centre``)."""
        if not detections:
            return np.zeros((0, 2))
        centres = [blob_centre(image, d) if self.refine_centres else d.centre_px for d in detections]
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

    # --- matching -------------------------------------------------------------------------
    def match(self, left: Sequence[Detection], right: Sequence[Detection],
              rect_left: np.ndarray, rect_right: np.ndarray) -> list[tuple[int, int, float]]:
        """Pairs (i_left, j_right, cost) of one-to-one matches, cheapest first (greedy)."""
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
                candidates.append((dy / self.max_dy_px + ratio / log_ratio, i, j))
        candidates.sort()
        used_l, used_r, pairs = set(), set(), []
        for cost, i, j in candidates:
            if i in used_l or j in used_r:
                continue
            used_l.add(i)
            used_r.add(j)
            pairs.append((i, j, cost))
        return pairs

    # --- one frame ------------------------------------------------------------------------
    def detect(self, image) -> list[Detection]:
        found: list[Detection] = []
        for detector in self.detectors:
            found.extend(detector.detect(image))
        return found

    def process(self, frame: StereoFrame) -> list[ObjectObservation]:
        """Detect, match, triangulate and track the objects of one stereo frame."""
        last = self._last
        if (frame.repeated and last is not None and last[0].left is frame.left
                and last[0].right is frame.right):
            return list(last[1])
        t = float(frame.t)
        if self._t is not None and t < self._t:
            self.reset()  # time went backwards (a replay restarted): the tracks mean nothing now
        self._t = t
        t_right = t + float(frame.skew_s)
        left, right = self.detect(frame.left), self.detect(frame.right)
        rect_l = self.rectify("left", left, frame.left)
        rect_r = self.rectify("right", right, frame.right)
        pairs = self.match(left, right, rect_l, rect_r)

        out: list[ObjectObservation] = []
        if pairs:
            idx_l = [i for i, _, _ in pairs]
            idx_r = [j for _, j, _ in pairs]
            _, base_raw = self.triangulate(rect_l[idx_l], rect_r[idx_r])
            assignment = self._associate(t, [left[i] for i in idx_l], base_raw)
        else:
            assignment = []
        updated = set()
        for k, (i, j, _) in enumerate(pairs):
            track = assignment[k]
            updated.add(track.object_id)
            out.append(self._measure(track, t, t_right, frame.skew_s, left[i], right[j], rect_l[i], rect_r[j]))

        # tracked objects seen in one view only: reported, not triangulated
        used_l = {i for i, _, _ in pairs}
        used_r = {j for _, j, _ in pairs}
        for track in list(self.tracks.values()):
            if track.object_id in updated:
                continue
            track.missed += 1
            if track.missed > self.drop_after:
                del self.tracks[track.object_id]
                self.lost[track.object_id] = (track, t)  # it may come back (re-enters the view)
                continue
            single = self._single_view(track, t, left, right, rect_l, rect_r, used_l, used_r)
            if single is not None:
                out.append(single)
        out.sort(key=lambda o: o.object_id)
        self._last = (frame, out)
        return list(out)

    def _associate(self, t: float, dets: Sequence[Detection], base_p: np.ndarray) -> list[_ObjectTrack]:
        """The track of each matched pair (greedy nearest prediction within the gate; new tracks otherwise)."""
        candidates = []
        for k, d in enumerate(dets):
            for track in self.tracks.values():
                if track.kind != d.kind or track.label != d.label:
                    continue
                pred = track.predicted(t)
                if pred is None:
                    continue
                dist = float(np.linalg.norm(base_p[k] - pred))
                if dist < self.gate_m:
                    candidates.append((dist, k, track.object_id))
        candidates.sort()
        chosen: dict[int, _ObjectTrack] = {}
        taken = set()
        for dist, k, object_id in candidates:
            if k in chosen or object_id in taken:
                continue
            chosen[k] = self.tracks[object_id]
            taken.add(object_id)
        # second chance before a new id: the same kind and label near where a live track was last
        # measured (it sped up past its prediction), else a recently lost one (it left and came back)
        for k, d in enumerate(dets):
            if k in chosen:
                continue
            track = self._reacquire(t, d, base_p[k], taken)
            if track is not None:
                chosen[k] = track
                taken.add(track.object_id)
        result = []
        for k, d in enumerate(dets):
            if k not in chosen:
                track = _ObjectTrack(self._next_id, d.kind, d.label,
                                     ConstantVelocityKalman(self.process_noise, self.measurement_noise),
                                     self.velocity_history)
                self.tracks[track.object_id] = track
                self._next_id += 1
                chosen[k] = track
            result.append(chosen[k])
        return result

    def _reacquire(self, t: float, d: Detection, p: np.ndarray, taken: set) -> Optional[_ObjectTrack]:
        """A live track of this label within ``REACQUIRE_M`` of its last position, or one lost in
        the last ``LOST_KEEP_S`` — the nearest; None when there is none."""
        best, best_dist = None, math.inf
        for track in self.tracks.values():
            if track.object_id in taken or track.kind != d.kind or track.label != d.label:
                continue
            last = track.kf.position
            dist = math.inf if last is None else float(np.linalg.norm(p - last))
            if dist < REACQUIRE_M and dist < best_dist:
                best, best_dist = track, dist
        if best is not None:
            return best
        for object_id, (track, t_lost) in list(self.lost.items()):
            if t - t_lost > LOST_KEEP_S:
                del self.lost[object_id]
                continue
            if object_id in taken or track.kind != d.kind or track.label != d.label:
                continue
            last = track.kf.position
            dist = math.inf if last is None else float(np.linalg.norm(p - last))
            if dist < LOST_REACQUIRE_M and dist < best_dist:
                best, best_dist = track, dist
        if best is not None:
            del self.lost[best.object_id]
            best.missed = 0
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
        return ObjectObservation(
            object_id=track.object_id, kind=dl.kind, label=dl.label, score=min(dl.score, dr.score),
            left=dl, right=dr, camera_p=_point(camera_p[0]), base_p=_point(base_p[0]),
            velocity_base=None if track.frames < 2 or v is None else _point(v),
            epipolar_dy_px=float(rl[1] - rr[1]), seen_left=True, seen_right=True, triangulated=True,
            disparity_px=float(pl[0] - pr[0]), skew_compensated=compensated, frames_tracked=track.frames,
        )

    def _single_view(self, track: _ObjectTrack, t: float, left, right, rect_l, rect_r,
                     used_l: set, used_r: set) -> Optional[ObjectObservation]:
        """The track's object when one view still sees it near the predicted position."""
        pred = track.predicted(t)
        if pred is None:
            return None
        for side, dets, rect, used in (("left", left, rect_l, used_l), ("right", right, rect_r, used_r)):
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
                camera_p = np.linalg.solve(self.base_T_camera[:3, :3], pred - self.base_T_camera[:3, 3])
                v = track.kf.velocity
                return ObjectObservation(
                    object_id=track.object_id, kind=d.kind, label=d.label, score=d.score,
                    left=d if side == "left" else None, right=d if side == "right" else None,
                    camera_p=_point(camera_p), base_p=_point(pred),
                    velocity_base=None if track.frames < 2 or v is None else _point(v),
                    epipolar_dy_px=None, seen_left=side == "left", seen_right=side == "right",
                    triangulated=False, frames_tracked=track.frames,
                )
        return None
