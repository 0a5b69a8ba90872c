"""The desk detector's dataset (core.sim.dataset): labels agree with the simulator's ground truth,
scenes are reproducible, and held-out seeds never overlap the training ones."""
import numpy as np
import pytest

from core.sim.dataset import (
    CLASSES,
    TEST_SEED_BASE,
    desk_for,
    held_out_seeds,
    random_scene,
    render_scene,
    render_views,
    training_arrays,
    training_seeds,
)
from core.sim.scenarios import thing_kind

SEEDS = (3, 11, 12)  # scenes with panels, handles, balls, cups, plushes and discs between them


@pytest.fixture(scope="module")
def scenes():
    return {seed: (random_scene(seed), render_scene(seed)) for seed in SEEDS}


def test_every_class_appears_in_the_sample_scenes(scenes):
    labels = {b.label for _, pair in scenes.values() for sample in pair for b in sample.boxes}
    assert labels == set(CLASSES)


def test_each_box_contains_its_objects_projected_truth_point(scenes):
    checked = 0
    for seed, ((state, settings, arm, desk_index), pair) in scenes.items():
        desk = desk_for(desk_index)
        truth = {o.marker_id: o for o in desk.truth(float(seed), arm).objects}
        for sample in pair:
            for b in sample.boxes:
                if b.difficult:
                    continue
                obj = truth[b.truth_id]
                assert obj.kind == b.label, f"seed {seed} {sample.side}: {b.name} is a {obj.kind}, labelled {b.label}"
                u, v = desk.rig.project(sample.side, np.array(obj.base_p_centre))[0]
                x0, y0, x1, y1 = b.box  # pixel edges; pixel centres are at i + 0.5 - 0.5 = i
                # the truth point of a cup or a disc is its top's middle: inside the box, 1 px slack
                assert x0 - 1.5 <= u <= x1 + 0.5 and y0 - 1.5 <= v <= y1 + 0.5, (
                    f"seed {seed} {sample.side}: {b.name} at ({u:.1f}, {v:.1f}) outside its box {b.box}")
                checked += 1
    assert checked > 30


def test_mostly_hidden_or_tiny_objects_are_difficult_and_the_rest_are_not(scenes):
    for seed, (_, pair) in scenes.items():
        for sample in pair:
            for b in sample.boxes:
                assert b.label in CLASSES
                assert thing_kind(b.name) == b.label, f"{b.name} labelled {b.label}"
                hidden = b.visible_fraction < 0.5
                if hidden:
                    assert b.difficult, f"seed {seed}: {b.name} shows {b.visible_fraction:.0%} but is not difficult"
                elif (b.box[2] - b.box[0]) * (b.box[3] - b.box[1]) >= 24:
                    assert not b.difficult, f"seed {seed}: {b.name} is visible but difficult"


def test_renders_and_labels_are_reproducible():
    a, b = render_scene(12), render_scene(12)
    assert np.array_equal(a[0].image, b[0].image) and a[0].boxes == b[0].boxes
    assert not np.array_equal(a[0].image, render_scene(13)[0].image)


def test_held_out_seeds_never_overlap_training_seeds():
    train = set(training_seeds(5000))
    held_out = set(held_out_seeds(500))
    assert not train & held_out
    assert min(held_out) == TEST_SEED_BASE > max(train)
    with pytest.raises(ValueError, match="below"):
        training_seeds(10, TEST_SEED_BASE - 5)
    with pytest.raises(ValueError, match="held-out seeds start"):
        held_out_seeds(10, 0)


def test_held_out_scenes_use_desks_training_never_sees_but_also_the_default_one():
    train_desks = {random_scene(s)[3] for s in range(200)}
    test_desks = {random_scene(s)[3] for s in held_out_seeds(200)}
    assert 0 in test_desks and len(test_desks - train_desks) == 3


def test_training_arrays_are_letterboxed_and_cached(tmp_path, monkeypatch):
    import core.sim.dataset as dataset

    monkeypatch.setattr(dataset, "CHUNK_SCENES", 3)
    images, boxes, labels, difficult = training_arrays(7, (320, 240), tmp_path)  # 4 scenes
    assert images.shape == (7, 240, 320, 3) and images.dtype == np.uint8
    assert len(boxes) == len(labels) == len(difficult) == 7
    full = render_views(0, view="both")[0]  # the training mix: scene 0 is one of the stereo rig's or the hand camera's
    assert np.allclose(boxes[0], np.array([b.box for b in full.boxes]).reshape(-1, 4) * 0.5)
    assert list(labels[0]) == [CLASSES.index(b.label) for b in full.boxes]
    assert sorted(p.name[-13:] for p in tmp_path.glob("*.npz")) == ["0000000-3.npz", "0000003-1.npz"]
    again = training_arrays(7, (320, 240), tmp_path)
    assert np.array_equal(again[0], images)


# --- the hand camera's views (the assistive arm's eye-in-hand camera) --------------------------------
def test_hand_camera_pose_sees_the_point_where_asked_with_the_axis_held_as_the_arm_holds_it():
    import math

    from core.sim.dataset import hand_camera_pose
    from core.sim.hand_camera import HandCameraConfig

    K = HandCameraConfig().K
    point = np.array([0.05, 0.15, 0.02])
    T = hand_camera_pose(point, 0.2, (400.0, 300.0), K, tilt_rad=math.radians(30))
    camera_p = np.linalg.inv(T) @ np.append(point, 1.0)
    uv = (K @ camera_p[:3])[:2] / camera_p[2]
    assert np.allclose(uv, (400.0, 300.0), atol=1e-6) and abs(camera_p[2] - 0.2) < 1e-9
    x_axis, optical_axis = T[:3, 0], T[:3, 2]
    assert abs(x_axis[2]) < 1e-9  # the image's x axis stays horizontal (no spin about the axis)
    assert math.degrees(math.acos(-optical_axis[2])) == pytest.approx(30.0, abs=1e-6)
    # tilted back towards the base: the axis points horizontally from the camera towards the base's z axis
    assert float(np.dot(optical_axis[:2], T[:2, 3])) < 0


def test_hand_camera_pose_is_the_pose_the_arm_itself_takes_to_aim_at_the_panel():
    import math

    from core.kinematics.clik import ClikKinematics
    from core.kinematics.profile import load_profile
    from core.motion.servoing import aimed_pose
    from core.sim.dataset import hand_camera_pose
    from core.sim.hand_camera import HandCameraConfig
    from core.sim.scenarios import Panel, PanelScenario

    K = HandCameraConfig().K
    kin = ClikKinematics(load_profile("assistive_5dof"))
    panel = Panel(*PanelScenario.PANEL_XY, yaw=PanelScenario.PANEL_YAW)
    point = np.array([panel.x, panel.y, panel.top_z])
    arm_T = kin.camera_pose(aimed_pose(kin, K, point, kin.q_home, math.radians(30)))
    camera_p = np.linalg.inv(arm_T) @ np.append(point, 1.0)
    pixel = (K @ camera_p[:3])[:2] / camera_p[2]
    mine = hand_camera_pose(point, float(camera_p[2]), pixel, K, math.radians(30))
    turn = math.degrees(math.acos(np.clip((np.trace(arm_T[:3, :3].T @ mine[:3, :3]) - 1) / 2, -1, 1)))
    assert turn < 1.0 and np.linalg.norm(arm_T[:3, 3] - mine[:3, 3]) < 0.003, (turn, arm_T, mine)


def test_about_a_third_of_the_training_mix_are_hand_camera_scenes_and_each_view_can_be_asked_for():
    from core.sim.dataset import HAND_SHARE, is_hand_scene

    share = np.mean([is_hand_scene(seed) for seed in range(600)])
    assert abs(share - HAND_SHARE) < 0.06
    hand_seed = next(seed for seed in range(50) if is_hand_scene(seed))
    assert {s.side for s in render_views(hand_seed, view="both")} == {"hand"}
    assert {s.side for s in render_views(hand_seed, view="stereo")} == {"left", "right"}
    with pytest.raises(ValueError, match="view 'top'"):
        render_views(hand_seed, view="top")


@pytest.fixture(scope="module")
def hand_scenes():
    from core.sim.dataset import random_hand_scene, render_hand_scene

    seeds = (TEST_SEED_BASE + 7, 21, 40)
    return {seed: (random_hand_scene(seed), render_hand_scene(seed)) for seed in seeds}


def test_hand_views_show_the_panel_s_buttons_and_each_box_holds_its_button_s_centre(hand_scenes):
    from core.sim.hand_camera import HandCameraConfig

    K = HandCameraConfig().K
    checked = 0
    for seed, ((state, _settings, _desk, poses), pair) in hand_scenes.items():
        panel = state.panels[0]
        centres = {panel.button_truth_id(n): panel.button_centre(n) for n in panel.BUTTONS}
        for pose, sample in zip(poses, pair):
            assert sample.side == "hand" and sample.image.shape == (480, 640, 3)
            buttons = [b for b in sample.boxes if b.label == "button" and not b.difficult]
            assert buttons, f"hand scene {seed}: no button in view"
            for b in buttons:
                camera_p = np.linalg.inv(pose) @ np.append(centres[b.truth_id], 1.0)
                u, v = (K @ camera_p[:3])[:2] / camera_p[2]
                x0, y0, x1, y1 = b.box
                assert x0 - 1.5 <= u <= x1 + 0.5 and y0 - 1.5 <= v <= y1 + 0.5, (
                    f"hand scene {seed}: {b.name} at ({u:.1f}, {v:.1f}) outside its box {b.box}")
                checked += 1
    assert checked >= 20


def test_hand_scenes_are_reproducible_and_differ_between_seeds(hand_scenes):
    from core.sim.dataset import render_hand_scene

    seed, (_, pair) = next(iter(hand_scenes.items()))
    again = render_hand_scene(seed)
    assert np.array_equal(again[1].image, pair[1].image) and again[1].boxes == pair[1].boxes
    assert not np.array_equal(render_hand_scene(seed + 1)[1].image, pair[1].image)
