"""End-to-end: ``--detector`` locates the objects scenario's marker-less things and the headless
JSON scores them against the simulated desk's ground truth."""
import json
import math

import pytest

from app.cli import main
from app.headless import (
    HeadlessRunner,
    detector_labels,
    label_matches,
    label_specificity,
)
from core.session import DeskSession, SessionOptions

OBJECT_KEYS = ("targets_seen_ratio", "error_3d_mm_p50_by_kind", "error_3d_mm_p95_by_kind", "id_switches",
               "velocity_error_mm_s_p50")


def json_summary(capsys, argv):
    code = main(argv)
    assert code == 0
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


def test_objects_scenario_with_hsv_is_scored_per_kind(capsys):
    s = json_summary(capsys, ["--headless", "--fast", "--camera", "sim", "--scenario", "objects",
                              "--detector", "hsv", "--duration", "10", "--json"])
    for key in OBJECT_KEYS:
        assert key in s, key
    # the default colours name all but the white cup: 3 balls, the plush, 2 discs, the pink cup.
    # A colour blob's centroid is the middle of what is seen of an object (top and side): on the
    # 4.5 cm purple cylinder ~2 cm below its top (the truth point), on the pink cup ~3.4 cm (not
    # seen at OBJECT_SEEN_M); hsv with circles finds the tops (next test). Measured 0.80.
    assert math.isfinite(s["targets_seen_ratio"]) and 0.7 < s["targets_seen_ratio"] <= 1.0
    p50, p95 = s["error_3d_mm_p50_by_kind"], s["error_3d_mm_p95_by_kind"]
    assert set(p50) == set(p95) == {"ball", "plush", "disc"}
    for kind in p50:
        assert math.isfinite(p50[kind]) and math.isfinite(p95[kind]) and p50[kind] <= p95[kind]
        assert p95[kind] <= 30.0  # only observations within OBJECT_SEEN_M are error samples
    assert p50["ball"] < 2.0 and p95["ball"] < 6.0  # ~0.7 / 0.85 mm measured
    assert p50["plush"] < 6.0  # ~2.0 mm measured
    assert s["id_switches"] == 0
    assert s["velocity_error_mm_s_p50"] is not None and math.isfinite(s["velocity_error_mm_s_p50"])
    # the markers are still scored as before
    assert s["markers_seen_ratio"] > 0.9


def test_hsv_with_circles_sees_every_kind_at_its_top_with_one_id_each(capsys):
    """The ellipse of a disc's or cup's top fuses with the colour blob (one track, the colour's
    label, the top's centre); the white cup is a "circle" track; circles on the balls merge into
    their blobs. Measured over 20 s: seen 0.995, ball 0.72 / 0.85 mm, plush 2.0 / 3.3, disc 1.3 /
    8.0, cup 1.9 / 2.2 (p50 / p95), 0 id switches."""
    s = json_summary(capsys, ["--headless", "--fast", "--camera", "sim", "--scenario", "objects",
                              "--detector", "hsv,circles", "--duration", "6", "--json"])
    assert s["targets_seen_ratio"] >= 0.95
    p50, p95 = s["error_3d_mm_p50_by_kind"], s["error_3d_mm_p95_by_kind"]
    assert set(p50) == {"ball", "plush", "disc", "cup"}
    assert p50["ball"] < 2.0 and p95["ball"] < 6.0
    assert p50["disc"] < 4.0 and p50["cup"] < 4.0
    assert s["id_switches"] == 0


def test_without_detector_the_json_has_no_object_metrics(capsys):
    s = json_summary(capsys, ["--headless", "--fast", "--camera", "sim", "--scenario", "static",
                              "--duration", "1", "--json"])
    for key in OBJECT_KEYS + ("object_perception_ms_p50",):
        assert key not in s, key


def test_session_builds_object_perception_only_when_asked():
    session = DeskSession.create(SessionOptions(camera="sim", scenario="objects", simulated_clock=True,
                                                detectors=("hsv",)))
    try:
        assert session.object_perception is not None
        assert [d.name for d in session.object_perception.detectors] == ["hsv"]
    finally:
        session.close()
    session = DeskSession.create(SessionOptions(camera="sim", scenario="objects", simulated_clock=True))
    try:
        assert session.object_perception is None
        assert HeadlessRunner(session, 0.2).run().summary().get("targets_seen_ratio") is None
    finally:
        session.close()


@pytest.mark.parametrize("bad, words", [("nosuch", "unknown detector 'nosuch'"), ("hsv,,circles", "empty item"),
                                        ("hsv,hsv", "listed twice")])
def test_bad_detector_exits_2_with_the_message(capsys, bad, words):
    code = main(["--headless", "--fast", "--scenario", "objects", "--detector", bad, "--duration", "1"])
    assert code == 2
    err = capsys.readouterr().err
    assert "--detector" in err and words in err
    if words.startswith("unknown"):
        assert "valid: aruco, hsv, circles" in err


def test_session_options_validate_the_detector_list():
    with pytest.raises(ValueError, match="unknown detector 'nope'"):
        SessionOptions(detectors=("nope",)).validate()
    options = SessionOptions(detectors=(" hsv", "circles "))
    options.validate()
    assert options.detectors == ("hsv", "circles")


def test_label_matches_colour_kind_or_whole_label():
    assert label_matches("red", "red ball") and label_matches("ball", "red ball")
    assert label_matches("red ball", "red ball")
    assert not label_matches("red", "orange disc") and not label_matches("", "red ball")


def test_a_circle_names_round_kinds_less_specifically_than_a_colour():
    for truth in ("red ball", "orange disc", "white cup"):
        assert label_matches("circle", truth) and label_specificity("circle", truth) == 1
    assert not label_matches("circle", "yellow plush") and label_specificity("circle", "yellow plush") == 0
    assert label_specificity("orange", "orange disc") == 2 and label_specificity("disc", "orange disc") == 2


def test_detector_labels_name_colours_and_circles():
    class _Perception:
        def __init__(self, detectors):
            self.detectors = detectors

    from core.detect.registry import make_detector

    labels = detector_labels(_Perception([make_detector("hsv"), make_detector("circles"), make_detector("aruco")]))
    assert "circle" in labels and {"red", "orange", "purple", "pink"} <= set(labels)
    assert detector_labels(_Perception([make_detector("circles")])) == ("circle",)

    class _Model:
        name = "onnx:x.onnx"
        params = object()

    assert detector_labels(_Perception([make_detector("hsv"), _Model()])) is None  # free class names
    assert detector_labels(None) is None


def _scored(observations, truths, detectors=("hsv", "circles")):
    """Score one frame of ``observations`` against ``truths`` with a bare runner (no session run)."""
    from types import SimpleNamespace

    from app.headless import RunMetrics
    from core.messages import GroundTruth, ObjectTruth

    runner = HeadlessRunner.__new__(HeadlessRunner)
    runner.metrics = RunMetrics(scenario="objects", objects=True)
    runner._object_labels = None if detectors is None else tuple(
        lab for d in detectors for lab in (("circle",) if d == "circles" else ("red", "white")))
    runner._object_ids, runner._object_truth_prev = {}, {}
    objs = tuple(ObjectTruth(marker_id=-11 - k, base_p_centre=p, visible_left=True, visible_right=True, label=lab,
                             kind=lab.split()[-1]) for k, (lab, p) in enumerate(truths))
    for k, frame_obs in enumerate(observations):
        runner._score_objects(SimpleNamespace(t=k / 30.0, truth=GroundTruth(objects=objs)), frame_obs)
    return runner.metrics


def _obs(object_id, label, p):
    from types import SimpleNamespace

    return SimpleNamespace(object_id=object_id, label=label, base_p=p, triangulated=True, velocity_base=None)


def test_the_colour_track_scores_a_ball_whichever_track_is_nearer_and_ids_never_flip():
    ball = ("red ball", (0.1, 0.2, 0.025))
    frames = []
    for k in range(6):  # the circle track is nearer on odd frames
        near, far = (0.1005, 0.2, 0.025), (0.102, 0.2, 0.025)
        colour_p, circle_p = (far, near) if k % 2 else (near, far)
        frames.append([_obs(1, "red", colour_p), _obs(2, "circle", circle_p)])
    m = _scored(frames, [ball])
    assert m.object_id_switches == 0
    assert m.object_seen_pairs == 6
    errors = sorted(m.object_error("ball"))
    assert errors[0] == pytest.approx(0.5, abs=1e-6) and errors[-1] == pytest.approx(2.0, abs=1e-6)


def test_a_white_cup_is_scored_on_its_circle_track_and_a_far_observation_is_not_an_error():
    cup = ("white cup", (0.0, 0.3, 0.08))
    m = _scored([[_obs(3, "circle", (0.0, 0.301, 0.08))], [_obs(3, "circle", (0.0, 0.36, 0.08))]], [cup])
    assert m.object_visible_pairs == 2 and m.object_seen_pairs == 1
    assert list(m.object_error("cup")) == [pytest.approx(1.0, abs=1e-6)]  # the 6 cm one is "not seen", no sample


def test_an_id_change_of_the_same_labels_track_is_a_switch():
    ball = ("red ball", (0.1, 0.2, 0.025))
    m = _scored([[_obs(1, "red", ball[1])], [_obs(4, "red", ball[1])]], [ball])
    assert m.object_id_switches == 1


# --- following a marker-less object (--follow-object) -----------------------------------------
FOLLOW_ARGS = ["--headless", "--fast", "--camera", "sim", "--scenario", "objects", "--detector", "hsv", "--json"]


def test_following_the_still_green_ball_reaches_it_on_one_cubic_approach(capsys):
    s = json_summary(capsys, FOLLOW_ARGS + ["--follow-object", "green ball", "--duration", "6"])
    # watched for the stop_hold_s, then one stopped event and one approach from the home pose
    assert s["object_stops"] == 1 and s["object_approaches"] == 1
    assert s["time_to_reach_stopped_s_p50"] is not None and 1.0 < s["time_to_reach_stopped_s_p50"] < 4.0
    assert s["arrival_speed_mm_s_p50"] is not None and s["arrival_speed_mm_s_p50"] < 30.0  # ~8.5 measured
    # on it: the ball's pointing position is 3.6 mm out of reach; the error is to the nearest point
    assert s["object_follow_samples"] > 50
    assert s["object_follow_error_mm_p50"] < 3.0 and s["object_follow_error_mm_p95"] < 5.0  # ~0.5 measured
    assert s["limit_violations"] == 0


def test_following_the_moving_red_ball_with_and_without_intercept(capsys):
    runs = {}
    for extra in ([], ["--no-intercept"]):
        runs[bool(extra)] = json_summary(capsys, FOLLOW_ARGS + ["--follow-object", "red ball", "--duration", "5"]
                                         + extra)
    with_intercept, without = runs[False], runs[True]
    for s in (with_intercept, without):
        assert s["object_stops"] == 0  # it never stops on its ellipse
        assert s["object_follow_samples"] > 100
        assert s["object_follow_error_mm_p50"] < 4.0 and s["object_follow_error_mm_p95"] < 6.0
        assert s["limit_violations"] == 0
    # the servo's whole degrees (~1.7 mm at this reach) dominate; the lead still shows at the p95
    assert with_intercept["object_follow_error_mm_p95"] < without["object_follow_error_mm_p95"]


def test_follow_object_without_a_detector_exits_2_with_the_fix(capsys):
    code = main(["--headless", "--fast", "--scenario", "objects", "--follow-object", "red ball", "--duration", "1"])
    assert code == 2
    err = capsys.readouterr().err
    assert "--follow-object 'red ball' needs a detector" in err and "--detector hsv" in err
    assert main(["--headless", "--fast", "--scenario", "objects", "--no-intercept", "--duration", "1"]) == 2
    assert "--no-intercept only changes --follow-object" in capsys.readouterr().err


def test_follow_and_skew_options_reach_the_session():
    from core.messages import TargetMode

    session = DeskSession.create(SessionOptions(camera="sim", scenario="objects", simulated_clock=True,
                                                detectors=("hsv",)))
    try:
        assert session.object_perception.compensate_skew
        assert session.targeter.mode is not TargetMode.OBJECT
    finally:
        session.close()
    session = DeskSession.create(SessionOptions(camera="sim", scenario="objects", simulated_clock=True,
                                                detectors=("hsv",), follow_object=" red ball ",
                                                object_intercept=False, compensate_skew=False))
    try:
        assert not session.object_perception.compensate_skew
        assert session.targeter.mode is TargetMode.OBJECT and session.targeter.follow_object_label == "red ball"
        assert not session.targeter.follower.params.intercept
    finally:
        session.close()
