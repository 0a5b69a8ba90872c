"""The simulated desk's objects scenario: marker-less things, their truth, the hand, --sim-skew-ms."""
import math

import numpy as np
import pytest

from core.messages import GroundTruth
from core.session import SCENARIOS as SESSION_SCENARIOS
from core.session import DeskSession, SessionOptions
from core.sim.desk import SimDesk, scenario_names
from core.sim.rig import SimRig
from core.sim.scenarios import THING_ID_BASE, THING_KINDS, ObjectsScenario, thing_kind

MAX_CHROMA_DEG = 8.0  # a pixel "has the object's colour" when its BGR vector is this close in angle


@pytest.fixture(scope="module")
def rig():
    return SimRig()


@pytest.fixture(scope="module")
def desk(rig):
    return SimDesk(rig, "objects")


def chroma_deg(bgr, colour) -> float:
    p, c = np.asarray(bgr, float), np.asarray(colour, float)
    return math.degrees(math.acos(min(1.0, float(p @ c) / (np.linalg.norm(p) * np.linalg.norm(c) + 1e-9))))


def things(truth: GroundTruth) -> dict[str, object]:
    return {o.label: o for o in truth.objects if o.marker_id <= THING_ID_BASE}


# ---------------------------------------------------------------------------------------------


def test_the_objects_scenario_is_offered_by_the_desk_and_the_session():
    assert "objects" in scenario_names()
    assert "objects" in SESSION_SCENARIOS
    SessionOptions(scenario="objects").validate()


def test_every_thing_has_a_negative_id_and_a_colour_kind_label(desk):
    truth = desk.truth(0.0)
    objs = things(truth)
    assert set(objs) == set(ObjectsScenario.LABELS)
    assert {thing_kind(label) for label in objs} == set(THING_KINDS)
    assert thing_kind("card 23") is None and thing_kind("cup A (ball)") is None
    ids = [o.marker_id for o in objs.values()]
    assert len(set(ids)) == len(ids) and max(ids) <= THING_ID_BASE < -1  # −1 stays the cups game's ball
    # the markers stay as before: cards with their ids, found by id
    assert {23, 50} <= set(truth.by_id())


@pytest.mark.parametrize("t", [0.0, 3.3, 13.0])
def test_the_projected_truth_lands_on_the_objects_pixels(rig, desk, t):
    """Each visible thing's truth point, projected by the rig, falls on pixels of its colour;
    the bare desk there has another colour (so the check can fail)."""
    left, right, truth = desk.render(t)
    colours = {th.truth_id: th.colour for th in desk.scene(t).things}
    checked = 0
    for side, img in (("left", left), ("right", right)):
        bare = desk._views[side].desk
        for obj in things(truth).values():
            if not getattr(obj, f"visible_{side}"):
                continue
            u, v = np.round(rig.project(side, np.array([obj.base_p_centre]))[0]).astype(int)
            patch = img[v - 1:v + 2, u - 1:u + 2].reshape(-1, 3).mean(axis=0)
            colour = colours[obj.marker_id]
            assert chroma_deg(patch, colour) < MAX_CHROMA_DEG, \
                f"t={t} {side} {obj.label}: pixel {patch} at ({u}, {v}) is not its colour {colour}"
            assert chroma_deg(bare[v, u], colour) > MAX_CHROMA_DEG
            checked += 1
    assert checked >= 14  # most things were visible in both views


def test_the_hand_hides_the_orange_disc_for_a_while_in_both_views(rig, desk):
    sc = ObjectsScenario
    hover = sc.HAND_OFFSET_S + sc.HAND_IN_S + sc.HAND_HOVER_S / 2
    for t, seen in ((sc.HAND_OFFSET_S - 0.5, True), (hover, False), (hover + sc.HAND_PERIOD_S, False),
                    (sc.HAND_OFFSET_S + 2 * sc.HAND_IN_S + sc.HAND_HOVER_S + 0.5, True)):
        disc = things(desk.truth(t))["orange disc"]
        assert (disc.visible_left, disc.visible_right) == (seen, seen), f"t={t}"
    left, _, truth = desk.render(hover)
    disc = things(truth)["orange disc"]
    u, v = np.round(rig.project("left", np.array([disc.base_p_centre]))[0]).astype(int)
    assert chroma_deg(left[v, u], (30, 125, 240)) > MAX_CHROMA_DEG  # the hand's colour there
    others = [o for label, o in things(truth).items() if label != "orange disc"]
    assert all(o.visible_left and o.visible_right for o in others if o.label != "blue ball")


def test_the_blue_ball_leaves_both_views_and_comes_back(rig, desk):
    sc = ObjectsScenario
    w, h = rig.size
    away = sc.BLUE_OFFSET_S + sc.BLUE_TRIP_S / 2
    for t, seen in ((0.0, True), (away, False), (sc.BLUE_OFFSET_S + sc.BLUE_TRIP_S + 0.5, True)):
        ball = things(desk.truth(t))["blue ball"]
        assert (ball.visible_left, ball.visible_right) == (seen, seen), f"t={t}"
    ball = things(desk.truth(away))["blue ball"]
    for side in ("left", "right"):  # out of the image, not merely covered
        u, v = rig.project(side, np.array([ball.base_p_centre]))[0]
        assert not (0 <= u < w and 0 <= v < h), f"{side}: ({u:.0f}, {v:.0f})"


def test_things_move_smoothly_at_desk_speeds():
    sc = ObjectsScenario((23, 50))
    dt = 0.02
    ts = np.arange(0.0, 16.0 + dt / 2, dt)
    paths = {label: [] for label in sc.LABELS}
    for t in ts:
        for th in sc.state(float(t)).things:
            paths[th.label].append(th.centre)
    speed = {label: np.linalg.norm(np.diff(np.array(p), axis=0), axis=1) / dt for label, p in paths.items()}
    for label in ("red ball", "blue ball", "yellow plush"):
        assert 0.05 <= speed[label].max() <= 0.2, f"{label}: peak {speed[label].max():.3f} m/s"
        assert np.abs(np.diff(speed[label])).max() < 0.02, f"{label}: jerky"
    for label in ("green ball", "orange disc", "purple disc", "white cup", "pink cup"):
        assert speed[label].max() == 0.0, label


def test_the_existing_scenarios_have_no_things(desk, rig):
    for name in ("static", "cups", "wander"):
        d = SimDesk(rig, name)
        assert d.scene(1.0).things == ()
        assert all(o.marker_id > THING_ID_BASE for o in d.truth(1.0).objects)


def test_the_recorded_truth_keeps_ids_labels_and_points(desk):
    topics = pytest.importorskip("core.record.topics")
    truth = desk.truth(0.0)
    msg = topics.truth_marker_array(truth, 1.0)
    got = {int(m.id): (str(m.text), (m.pose.position.x, m.pose.position.y, m.pose.position.z)) for m in msg.markers}
    for o in truth.objects:
        assert got[o.marker_id][0] == o.label
        assert np.allclose(got[o.marker_id][1], o.base_p_centre)


def test_sim_skew_ms_reaches_the_simulated_camera():
    session = DeskSession.create(SessionOptions(camera="sim", scenario="objects", simulated_clock=True,
                                                sim_skew_ms=16))
    try:
        assert session.camera.skew_s == pytest.approx(0.016)
    finally:
        session.camera.disconnect()


@pytest.mark.parametrize("bad", [-1.0, 100.5, float("nan")])
def test_sim_skew_ms_outside_0_to_100_is_refused_naming_the_option(bad):
    with pytest.raises(ValueError, match="--sim-skew-ms"):
        SessionOptions(sim_skew_ms=bad).validate()


def test_the_cli_passes_sim_skew_ms_into_the_session_options(monkeypatch):
    import app.cli
    import app.headless

    seen = {}

    def fake_run_headless(options, duration, as_json, record=None, **kwargs):
        seen["options"] = options
        return 0

    monkeypatch.setattr(app.headless, "run_headless", fake_run_headless)
    assert app.cli.main(["--headless", "--camera", "sim", "--scenario", "objects", "--sim-skew-ms", "16"]) == 0
    assert seen["options"].sim_skew_ms == 16.0
    assert seen["options"].scenario == "objects"
    assert "unsynchronised webcams" in app.cli.build_parser().format_help()
