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
    full = render_scene(0)[0]
    assert np.allclose(boxes[0], np.array([b.box for b in full.boxes]).reshape(-1, 4) * 0.5)
    assert list(labels[0]) == [CLASSES.index(b.label) for b in full.boxes]
    assert sorted(p.name[-13:] for p in tmp_path.glob("*.npz")) == ["0000000-3.npz", "0000003-1.npz"]
    again = training_arrays(7, (320, 240), tmp_path)
    assert np.array_equal(again[0], images)
