"""The simulated desk's panel scene (a lift panel of 9 buttons and a door handle), image boxes,
and a SimDesk that renders any Scenario it is given."""
import cv2
import numpy as np
import pytest

from core.sim.desk import ImageBox, SimDesk, button_texture, scenario_names
from core.sim.rig import SimRig
from core.sim.scenarios import (
    BUTTON_ID_BASE,
    HANDLE_ID,
    WORKSPACE_X,
    WORKSPACE_Y,
    DoorHandle,
    ObjectsScenario,
    Panel,
    PanelScenario,
    Scenario,
    SceneState,
    Thing,
    make_scenario,
    thing_kind,
)


@pytest.fixture(scope="module")
def rig():
    return SimRig()


class FixedScene(Scenario):
    """A scenario that always shows the same SceneState (what a data generator builds)."""

    name = "fixed"

    def __init__(self, state: SceneState):
        super().__init__((23,))
        self._state = state

    def state(self, t: float) -> SceneState:
        return self._state


RED = (38, 38, 205)


def red_ball(x=0.0, y=0.12, r=0.02) -> Thing:
    return Thing("ball", "red ball", -11, x, y, r, 2 * r, RED)


# -- SimDesk takes a Scenario instance ----------------------------------------------------------


def test_the_desk_renders_a_scenario_instance_it_is_given(rig):
    desk = SimDesk(rig, FixedScene(SceneState(things=(red_ball(),))))
    assert desk.scenario == "fixed"
    left, _, truth = desk.render(0.0)
    (ball,) = truth.objects
    assert (ball.marker_id, ball.kind, ball.visible_left, ball.visible_right) == (-11, "ball", True, True)
    u, v = np.round(rig.project("left", np.array([ball.base_p_centre]))[0]).astype(int)
    assert left[v, u, 2] > 150 and left[v, u, 0] < 100  # red where the ball is
    desk.set_scenario(FixedScene(SceneState()))  # set_scenario takes one as well
    assert desk.truth(0.0).objects == ()
    desk.set_scenario("static")
    assert {o.marker_id for o in desk.truth(0.0).objects} == {23, 50}
    with pytest.raises(TypeError, match="Scenario instance"):
        desk.set_scenario(42)


def test_the_simulated_camera_keeps_a_given_scenario_when_its_rig_is_moved():
    from core.sim.camera import SimStereoCamera

    scene = FixedScene(SceneState(things=(red_ball(),)))
    camera = SimStereoCamera(scenario=scene)
    assert camera.scenario == "fixed" and "fixed" in camera.name
    camera.set_rig_offset((0.01, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert camera.desk.scenario_object is scene
    assert [o.label for o in camera.desk.truth(0.0).objects] == ["red ball"]


# -- image boxes --------------------------------------------------------------------------------


@pytest.mark.parametrize("x, y", [(0.0, 0.12), (-0.12, 0.06), (0.15, 0.2)])
def test_a_balls_box_holds_its_projected_centre_and_is_its_projected_diameter_wide(rig, x, y):
    r = 0.02
    desk = SimDesk(rig, FixedScene(SceneState(things=(red_ball(x, y, r),))))
    boxes = desk.image_boxes(0.0)
    for side in ("left", "right"):
        box = boxes[side][-11]
        assert isinstance(box, ImageBox) and (box.kind, box.label) == ("ball", "red ball")
        (u, v), = rig.project(side, np.array([[x, y, r]]))
        assert box.x0 <= u < box.x1 and box.y0 <= v < box.y1
        z = (np.linalg.inv(rig.base_T_left if side == "left" else rig.base_T_right) @ [x, y, r, 1.0])[2]
        diameter_px = 2 * r * rig.K[0, 0] / z
        assert abs(box.width - diameter_px) <= 1.5, f"{side}: {box.width} px wide, expected {diameter_px:.1f}"
        assert abs(box.height - diameter_px) <= 1.5
        assert abs(box.centre[0] - u) <= 1.0 and abs(box.centre[1] - v) <= 1.0
        assert box.visible_fraction == pytest.approx(1.0)


def test_a_box_is_tight_on_the_drawn_pixels(rig):
    """Inside the box the ball's colour reaches all four edges; outside it there is none."""
    desk = SimDesk(rig, FixedScene(SceneState(things=(red_ball(),))), noise_sigma=0.0, blur_sigma_px=0.0)
    left, _, _ = desk.render(0.0)
    box = desk.image_boxes(0.0)["left"][-11]
    bgr = left.astype(int)
    red = (bgr[..., 2] > 2 * bgr[..., 1]) & (bgr[..., 2] > 2 * bgr[..., 0])  # the desk is orange, not red
    ys, xs = np.nonzero(red)
    assert abs(xs.min() - box.x0) <= 1 and abs(xs.max() + 1 - box.x1) <= 1
    assert abs(ys.min() - box.y0) <= 1 and abs(ys.max() + 1 - box.y1) <= 1


def test_a_hand_over_an_object_shrinks_its_visible_box_and_fraction(rig):
    """The objects scenario's hand comes in over the orange disc: partly hidden, then gone."""
    desk = SimDesk(rig, "objects")
    disc = -15
    free = desk.image_boxes(5.0)["left"][disc]
    partly = desk.image_boxes(6.5)["left"][disc]
    assert free.visible_fraction == pytest.approx(1.0)
    assert 0.05 < partly.visible_fraction < 0.9
    assert partly.visible_px < free.visible_px and partly.width < free.width
    assert free.x0 <= partly.x0 and partly.x1 <= free.x1 and free.y0 <= partly.y0 and partly.y1 <= free.y1
    hover = ObjectsScenario.HAND_OFFSET_S + ObjectsScenario.HAND_IN_S + ObjectsScenario.HAND_HOVER_S / 2
    assert disc not in desk.image_boxes(hover)["left"] and disc not in desk.image_boxes(hover)["right"]


def test_an_object_half_out_of_the_image_has_a_clipped_box_and_about_half_its_pixels(rig):
    desk = SimDesk(rig, FixedScene(SceneState(things=(red_ball(),))))
    # the ball's x where its projected centre sits on the left image's edge (u = 0), by bisection:
    # the rig faces the arm, so u grows towards −x
    lo, hi = -0.6, 0.6
    for _ in range(50):
        x = (lo + hi) / 2
        (u, _), = rig.project("left", np.array([[x, 0.12, 0.02]]))
        lo, hi = (x, hi) if u > 0 else (lo, x)
    desk.set_scenario(FixedScene(SceneState(things=(red_ball(x=x),))))
    box = desk.image_boxes(0.0)["left"][-11]
    assert box.x0 == 0
    assert 0.4 < box.visible_fraction < 0.6
    assert desk.truth(0.0).objects[0].visible_left is False


def test_the_arm_hides_what_is_under_it(rig):
    desk = SimDesk(rig, FixedScene(SceneState(things=(red_ball(0.0, 0.15),))))
    # the tool on the line of sight from the left camera to the ball, 10 cm above the desk
    eye, ball = rig.base_T_left[:3, 3], np.array([0.0, 0.15, 0.02])
    tool = ball + (0.10 - ball[2]) / (eye[2] - ball[2]) * (eye - ball)
    arm = np.array([(0.0, 0.0, 0.0), (0.0, 0.0, 0.066), (0.0, 0.06, 0.17), tuple(tool)])
    free = desk.image_boxes(0.0)["left"][-11]
    covered = desk.image_boxes(0.0, arm)["left"].get(-11)
    assert covered is not None and covered.visible_fraction < free.visible_fraction - 0.1


# -- the panel scene ----------------------------------------------------------------------------

BUTTON_IDS = {BUTTON_ID_BASE - n: f"button {n}" for n in range(1, 10)}


@pytest.fixture(scope="module")
def panel_desk(rig):
    return SimDesk(rig, "panel")


@pytest.fixture(scope="module")
def clean_desk(rig):
    """The panel scene without blur and noise: pixel tests see the drawn colours."""
    return SimDesk(rig, "panel", blur_sigma_px=0.0, noise_sigma=0.0)


def grey(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Grey level (mean of B, G, R) of ``img`` at the rounded pixel positions ``uv`` (N, 2)."""
    px = np.round(uv).astype(int)
    return img[px[:, 1], px[:, 0]].astype(float).mean(axis=1)


def ring_points(centre, radius_m: float, n: int = 16) -> np.ndarray:
    a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([centre[0] + radius_m * np.cos(a), centre[1] + radius_m * np.sin(a),
                            np.full(n, centre[2])])


def test_the_panel_scenario_is_registered_and_builds_with_the_usual_marker_ids():
    assert "panel" in scenario_names()
    scenario = make_scenario("panel", (23, 50))
    assert isinstance(scenario, PanelScenario)
    st = scenario.state(0.0)
    assert len(st.panels) == 1 and len(st.handles) == 1 and {c.marker_id for c in st.cards} == {23, 50}


def test_buttons_and_the_handle_have_their_ids_kinds_and_labels(panel_desk):
    truth = panel_desk.truth(0.0)
    by_id = truth.by_id()
    for key, label in BUTTON_IDS.items():
        assert (by_id[key].label, by_id[key].kind) == (label, "button")
        assert thing_kind(label) == "button"
    handle = by_id[HANDLE_ID]
    assert (handle.label, handle.kind) == ("door handle", "handle") and thing_kind("door handle") == "handle"
    assert {23, 50} <= set(by_id) and by_id[23].kind == "marker"
    assert len(truth.objects) == 2 + 9 + 1
    # the old labels keep their kinds
    assert [thing_kind(x) for x in ("red ball", "white cup", "card 23", "cup A (ball)", "button")] == \
        ["ball", "cup", None, None, None]


def test_the_panel_numbers_its_buttons_row_major_from_the_far_row_as_seen_from_the_arm():
    panel = Panel(0.0, 0.1)
    centres = {n: np.array(panel.button_centre(n)) for n in range(1, 10)}
    assert centres[1][1] > centres[4][1] > centres[7][1]  # rows: 1 2 3 is the far one (+y)
    assert centres[1][0] < centres[2][0] < centres[3][0]  # columns: 1 on −x (the arm's left)
    assert np.allclose(centres[5], (0.0, 0.1, panel.thickness_m + panel.button_proud_m))
    assert np.isclose(np.linalg.norm(centres[2] - centres[1]), panel.button_pitch_m)
    assert panel.normal == (0.0, 0.0, 1.0) and panel.press_depth_m == pytest.approx(0.003)
    pressed = Panel(0.0, 0.1, pressed=(5,))
    assert pressed.button_centre(5)[2] == pytest.approx(centres[5][2] - panel.press_depth_m)
    assert pressed.button_centre(4)[2] == pytest.approx(centres[4][2])
    assert panel.button_pressed_centre(5)[2] == pytest.approx(pressed.button_centre(5)[2])
    turned = Panel(0.0, 0.1, yaw=np.pi / 2)  # a quarter turn: the far row now lies on −x
    assert turned.button_centre(1)[0] == pytest.approx(-panel.button_pitch_m)
    with pytest.raises(ValueError, match="1…9"):
        Panel(0.0, 0.1, lit=(10,))
    with pytest.raises(ValueError, match="1…9"):
        panel.button_centre(0)


def test_the_panel_and_handle_lie_in_the_arms_workspace():
    st = PanelScenario((23, 50)).state(0.0)
    panel, handle = st.panels[0], st.handles[0]
    assert np.allclose((panel.x, panel.y), (-0.03, 0.13))
    assert np.allclose(handle.centre[:2], (0.12, 0.13), atol=0.005)
    for x, y, _ in [panel.button_centre(n) for n in range(1, 10)] + [handle.centre, handle.tip]:
        assert WORKSPACE_X[0] <= x <= WORKSPACE_X[1] and WORKSPACE_Y[0] <= y <= WORKSPACE_Y[1]


def test_everything_is_seen_by_both_cameras_while_the_hand_is_away(panel_desk):
    truth = panel_desk.truth(1.0)
    assert all(o.visible_left and o.visible_right for o in truth.objects), \
        [o.label for o in truth.objects if not (o.visible_left and o.visible_right)]


@pytest.mark.parametrize("side", ["left", "right"])
def test_each_buttons_truth_point_lands_on_its_drawn_button(rig, clean_desk, side):
    """Around the projected truth point: the dark face within 0.5 r, the bright ring at 0.89 r,
    the plate (no dark pixel) between 1.5 r and 1.9 r; and the point is inside the button's box."""
    t = 1.0
    left, right, _ = clean_desk.render(t)
    img = left if side == "left" else right
    boxes = clean_desk.image_boxes(t)[side]
    panel = clean_desk.scene(t).panels[0]
    r = panel.button_radius_m
    for n in range(1, 10):
        centre = panel.button_centre(n)
        (u, v), = rig.project(side, np.array([centre]))
        box = boxes[panel.button_truth_id(n)]
        assert box.x0 <= u < box.x1 and box.y0 <= v < box.y1, f"{side} button {n}"
        inner = np.vstack([ring_points(centre, k * r) for k in (0.0, 0.25, 0.5)])
        ring_grey = grey(img, rig.project(side, ring_points(centre, 0.89 * r)))
        assert np.count_nonzero(ring_grey > 140) >= 14, f"{side} button {n}: ring not where expected {ring_grey}"
        plate = np.vstack([ring_points((*centre[:2], panel.top_z), k * r) for k in (1.5, 1.7, 1.9)])
        inner_grey = grey(img, rig.project(side, inner))
        plate_grey = grey(img, rig.project(side, plate))
        assert inner_grey.min() < 80, f"{side} button {n}: no dark face at its truth point ({inner_grey.min():.0f})"
        assert plate_grey.min() > 110, f"{side} button {n}: dark pixels where the plate should be"


def test_button_faces_carry_different_digits(rig, clean_desk):
    textures = [button_texture(n, False) for n in range(1, 10)]
    for i in range(9):
        for j in range(i + 1, 9):
            diff = np.abs(textures[i].astype(int) - textures[j].astype(int)).mean()
            assert diff > 3.0, f"buttons {i + 1} and {j + 1} look alike ({diff:.1f})"
    assert np.abs(button_texture(5, True).astype(int) - textures[4]).mean() > 3.0  # a lit ring shows
    # in the rendered view too: the faces (resampled to one size) differ pairwise
    t = 1.0
    left, _, _ = clean_desk.render(t)
    lit = clean_desk.scene(t).panels[0].lit
    boxes = clean_desk.image_boxes(t)["left"]
    crops = {n: cv2.resize(left[b.y0:b.y1, b.x0:b.x1], (24, 24), interpolation=cv2.INTER_AREA).astype(int)
             for n in range(1, 10) if n not in lit for b in [boxes[BUTTON_ID_BASE - n]]}
    keys = sorted(crops)
    for i, a in enumerate(keys):
        for b in keys[i + 1:]:
            assert np.abs(crops[a] - crops[b]).mean() > 6.0, f"buttons {a} and {b} look alike in the left view"


def test_the_lit_ring_scans_through_the_buttons():
    sc = PanelScenario((23,))
    assert [sc.state(k * sc.SCAN_S + 0.1).panels[0].lit for k in range(10)] == [(n,) for n in range(1, 10)] + [(1,)]


def test_the_door_handle_is_visible_and_drawn_where_its_truth_is(rig, clean_desk):
    left, right, truth = clean_desk.render(1.0)
    handle = truth.by_id()[HANDLE_ID]
    assert handle.visible_left and handle.visible_right
    boxes = clean_desk.image_boxes(1.0)
    for side, img in (("left", left), ("right", right)):
        box = boxes[side][HANDLE_ID]
        assert box.kind == "handle" and box.width > 80 and box.visible_fraction == pytest.approx(1.0)
        (u, v), = rig.project(side, np.array([handle.base_p_centre]))
        assert box.x0 <= u < box.x1 and box.y0 <= v < box.y1
        b, g, r = img[int(round(v)), int(round(u))].astype(int)
        assert max(b, g, r) - min(b, g, r) < 25 and r > 120, f"{side}: ({b}, {g}, {r}) is not the steel bar"
        bare = clean_desk._views[side].desk[int(round(v)), int(round(u))].astype(int)
        assert bare[2] - bare[0] > 40  # the desk there is orange wood (so the check above can fail)


def test_the_passing_hand_hides_the_near_column_of_buttons_then_leaves(panel_desk):
    sc = PanelScenario
    hover = sc.HAND_OFFSET_S + sc.HAND_IN_S + sc.HAND_HOVER_S / 2
    truth = panel_desk.truth(hover).by_id()
    for n in (1, 4, 7):
        assert not truth[BUTTON_ID_BASE - n].visible_left and not truth[BUTTON_ID_BASE - n].visible_right
    for n in (3, 6, 9):
        assert truth[BUTTON_ID_BASE - n].visible_left and truth[BUTTON_ID_BASE - n].visible_right
    boxes = panel_desk.image_boxes(hover)
    for side in ("left", "right"):
        for n in (3, 6, 9):
            assert boxes[side][BUTTON_ID_BASE - n].visible_fraction == pytest.approx(1.0)
        hidden = [boxes[side].get(BUTTON_ID_BASE - n) for n in (1, 4, 7)]
        assert all(b is None or b.visible_fraction < 0.6 for b in hidden), side
    assert panel_desk.scene(hover - sc.HAND_HOVER_S / 2 - sc.HAND_IN_S - 0.1).hands == ()
    later = panel_desk.truth(hover + sc.HAND_HOVER_S / 2 + sc.HAND_IN_S + 0.1)
    assert all(o.visible_left and o.visible_right for o in later.objects)


def test_a_pressed_button_sinks_by_its_press_depth_in_truth_and_picture(rig):
    up = Panel(-0.03, 0.13)
    down = Panel(-0.03, 0.13, pressed=(5,))
    desks = [SimDesk(rig, FixedScene(SceneState(panels=(p,))), blur_sigma_px=0.0, noise_sigma=0.0) for p in (up, down)]
    truths = [d.truth(0.0).by_id()[BUTTON_ID_BASE - 5] for d in desks]
    assert truths[0].base_p_centre[2] - truths[1].base_p_centre[2] == pytest.approx(up.press_depth_m)
    boxes = [d.image_boxes(0.0)["left"][BUTTON_ID_BASE - 5] for d in desks]
    assert boxes[1].visible_px < boxes[0].visible_px  # less of its side shows


def test_a_handle_is_a_scene_object_of_its_own():
    hd = DoorHandle(0.18, 0.13, yaw=np.pi, length_m=0.12)
    assert np.allclose(hd.centre, (0.12, 0.13, hd.bar_height_m + hd.thickness_m / 2))
    assert np.allclose(hd.tip, (0.06, 0.13, hd.bar_height_m))
