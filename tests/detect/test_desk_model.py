"""The detector deskarm ships (resources/models/desk_objects.onnx, ``make_detector("desk")``).

CI (no torch): the shipped file loads in OpenCV's DNN module, names its classes from its own
metadata and finds the objects of fresh held-out renders and of the app's scenarios — the stereo
rig's views and the assistive arm's hand camera's close, steep views of the lift panel.
With torch (the ``train`` extra): a few training steps on a handful of renders export a model
that OpenCV loads and whose output matches torch's.
"""
import numpy as np
import pytest

from core.detect.learned.evaluation import box_iou
from core.detect.learned.shipped import shipped_model_path
from core.detect.registry import make_detector
from core.sim.dataset import CLASSES, TEST_SEED_BASE, random_scene, render_scene

PICK_FROM = TEST_SEED_BASE + 5000  # away from eval-detector's default seeds (same held-out range)
MIN_RECALL = 0.9
# hand camera: the buttons it must find (non-difficult, IoU ≥ 0.5) out of those of fresh hand-camera
# renders; see test_it_finds_the_buttons_in_fresh_hand_camera_views for why this value
MIN_HAND_BUTTON_RECALL = 0.9


@pytest.fixture(scope="module")
def desk():
    return make_detector("desk", backend="cv2")


def scenes_with_every_class(count: int) -> list[int]:
    """Held-out scene seeds whose scenes hold a panel, a handle, and balls, cups and a plush."""
    seeds = []
    seed = PICK_FROM
    while len(seeds) < count:
        state = random_scene(seed)[0]
        kinds = {th.kind for th in state.things}
        if state.panels and state.handles and {"ball", "cup", "plush"} <= kinds:
            seeds.append(seed)
        seed += 1
    return seeds


def match(detections, boxes) -> tuple[int, int, list[str]]:
    """(found with the right class at IoU ≥ 0.5, owed, what was missed) for non-difficult boxes."""
    owed = [b for b in boxes if not b.difficult]
    found, missed = 0, []
    for b in owed:
        same = [d for d in detections if d.label == b.label]
        boxes_d = np.array([(d.box[0], d.box[1], d.box[0] + d.box[2], d.box[1] + d.box[3])
                            for d in same]).reshape(-1, 4)
        if len(same) and box_iou(np.array([b.box]), boxes_d).max() >= 0.5:
            found += 1
        else:
            missed.append(f"{b.name} {tuple(round(v) for v in b.box)}")
    return found, len(owed), missed


def test_the_shipped_model_is_small_and_runs_in_opencv_dnn_with_names_from_its_metadata(desk):
    path = shipped_model_path()
    assert path.is_file() and path.stat().st_size < 2.5e6
    assert desk.backend == "cv2" and desk.layout == "yolov8"
    assert desk.names == list(CLASSES) and desk.names_source == "model metadata"
    assert desk.input_wh == (320, 240)
    assert "map50" in desk.info.metadata.get("deskarm_eval", "")
    assert '"view": "hand"' in desk.info.metadata.get("deskarm_eval_hand", "")


def test_the_shipped_model_runs_in_opencv_classic_engine_as_in_the_new_one():
    """The shipped file runs in OpenCV 5's classic DNN engine (a third less CPU a pass on a Pi);
    its detections are the new engine's, on renders of every class."""
    import cv2

    from core.detect.learned.shipped import shipped_model_engine
    from core.detect.onnx_yolo import OnnxYoloDetector

    assert shipped_model_engine() == cv2.dnn.ENGINE_CLASSIC
    classic = make_detector("desk", backend="cv2")
    new = OnnxYoloDetector(shipped_model_path(), backend="cv2", engine=cv2.dnn.ENGINE_AUTO)
    found = 0
    for seed in scenes_with_every_class(3):
        image = render_scene(seed)[0].image
        a, b = classic.detect(image), new.detect(image)
        assert [d.label for d in a] == [d.label for d in b]
        for x, y in zip(a, b):
            assert abs(x.score - y.score) < 2e-3 and np.allclose(x.box, y.box, atol=0.05)
        found += len(a)
    assert found >= 10


def test_it_finds_every_kind_of_object_on_fresh_renders(desk):
    found = owed = 0
    missed, labels = [], set()
    for seed in scenes_with_every_class(2):
        for sample in render_scene(seed):
            detections = desk.detect(sample.image)
            f, o, m = match(detections, sample.boxes)
            found, owed = found + f, owed + o
            missed += [f"seed {seed} {sample.side}: {text}" for text in m]
            labels |= {b.label for b in sample.boxes if not b.difficult}
    assert {"ball", "cup", "plush", "button", "handle"} <= labels
    assert owed >= 30
    assert found / owed >= MIN_RECALL, f"recall {found}/{owed}; missed: {missed}"


@pytest.mark.parametrize("scenario, t, expected", [
    ("objects", 0.0, {"ball": 3, "plush": 1, "cup": 2, "disc": 2}),
    ("panel", 1.0, {"button": 9, "handle": 1}),
])
def test_it_finds_the_objects_of_the_apps_scenarios(desk, scenario, t, expected):
    from core.sim.desk import SimDesk
    from core.sim.rig import SimRig

    sim = SimDesk(SimRig(), scenario=scenario)
    left, right, _ = sim.render(t)
    boxes = sim.image_boxes(t)
    for side, image in (("left", left), ("right", right)):
        detections = desk.detect(image)
        for label, count in expected.items():
            truth = [b for b in boxes[side].values() if b.kind == label and b.visible_fraction > 0.5]
            assert len(truth) == count
            mine = [d for d in detections if d.label == label]
            ious = box_iou(np.array([(b.x0, b.y0, b.x1, b.y1) for b in truth], float),
                           np.array([(d.box[0], d.box[1], d.box[0] + d.box[2], d.box[1] + d.box[3])
                                     for d in mine]).reshape(-1, 4))
            hits = int((ious.max(axis=1) >= 0.5).sum()) if len(mine) else 0
            assert hits == count, f"{scenario} {side}: {hits}/{count} {label}s found ({[d.to_dict() for d in mine]})"


def test_it_finds_the_buttons_in_fresh_hand_camera_views(desk):
    """Held-out hand-camera scenes (the assistive arm's ready view and approaches, unseen desks).
    The model's held-out recall of buttons at score 0.25 is 1.00 (1453 buttons in 200 images,
    resources/models/README.md); on these 12 images (82 buttons) up to one miss in ten still
    passes (room for another runtime's rounding or a retrained model), while the stereo-only
    model it replaces found none of them (0/82: it fails this test)."""
    from core.sim.dataset import render_hand_scene

    found = owed = 0
    missed = []
    for seed in range(PICK_FROM, PICK_FROM + 6):
        for i, sample in enumerate(render_hand_scene(seed)):
            buttons = [b for b in sample.boxes if b.label == "button"]
            f, o, m = match(desk.detect(sample.image), buttons)
            found, owed = found + f, owed + o
            missed += [f"hand scene {seed} pose {i}: {text}" for text in m]
    assert owed >= 40
    assert found / owed >= MIN_HAND_BUTTON_RECALL, f"recall {found}/{owed}; missed (first 10): {missed[:10]}"


def test_the_readme_beside_the_model_states_its_score():
    readme = shipped_model_path().with_name("README.md").read_text(encoding="utf-8").lower()
    for needed in ("map@0.5", "deskarm train-detector", "deskarm eval-detector", "licence", *CLASSES):
        assert needed in readme, f"resources/models/README.md does not mention {needed!r}"


# --- training (torch only) -----------------------------------------------------------------------
def test_a_few_training_steps_export_a_model_opencv_runs_like_torch(tmp_path):
    torch = pytest.importorskip("torch")
    pytest.importorskip("onnx")
    import cv2

    from core.detect.learned.model import DeskNet, TrainConfig, decode, export_onnx, make_targets, train_detector
    from core.detect.onnx_yolo import OnnxYoloDetector
    from core.sim.dataset import training_arrays

    images, boxes, labels, difficult = training_arrays(8, (320, 240), tmp_path / "data")
    t = make_targets(boxes[0], labels[0], difficult[0], (240, 320), len(CLASSES))
    owed = ~difficult[0]
    assert int((t["heat"] >= 1.0).sum()) == len({(int(l), int((b[0] + b[2]) / 2 // 8), int((b[1] + b[3]) / 2 // 8))
                                                  for b, l in zip(boxes[0][owed], labels[0][owed])})
    config = TrainConfig(epochs=3, batch_size=4, max_seconds=0, threads=1, warmup_fraction=0.2)
    result = train_detector(images, boxes, labels, difficult, len(CLASSES), config)
    assert result.steps == 6 and np.isfinite(result.final_loss)
    assert isinstance(result.net, DeskNet) and not result.net.training

    path = export_onnx(result.net, tmp_path / "tiny.onnx", CLASSES, (320, 240))
    x = images[:1, ..., ::-1].transpose(0, 3, 1, 2).astype(np.float32) / 255.0  # RGB, as blobFromImage(swapRB)
    with torch.no_grad():
        expected = decode(*result.net(torch.from_numpy(np.ascontiguousarray(x)))).numpy()
    net = cv2.dnn.readNetFromONNX(str(path))
    net.setInput(x)
    got = net.forward()
    assert got.shape == expected.shape == (1, 4 + len(CLASSES), 40 * 30)
    assert np.allclose(got, expected, rtol=1e-3, atol=1e-3), float(np.abs(got - expected).max())
    detector = OnnxYoloDetector(path, backend="cv2")
    assert detector.names == list(CLASSES) and detector.layout == "yolov8"


# --- the command line ------------------------------------------------------------------------------
def test_eval_detector_prints_the_score_of_the_shipped_model_as_json(capsys):
    import json

    from app.cli_train import main

    assert main(["eval-detector", "--images", "4", "--seed", str(PICK_FROM), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["images"] == 4 and result["backend"] == "cv2" and result["first_seed"] == PICK_FROM
    assert set(result["classes"]) == set(CLASSES)
    assert 0.0 <= result["map"] <= 1.0
    assert result["timing"]["detect_ms_per_image"] > 0


def test_eval_detector_scores_hand_camera_views_when_asked(capsys):
    import json

    from app.cli_train import main

    assert main(["eval-detector", "--images", "2", "--seed", str(PICK_FROM), "--view", "hand", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["view"] == "hand" and result["images"] == 2
    assert result["classes"]["button"]["n_truth"] > 0


@pytest.mark.parametrize("argv, message", [
    (["eval-detector", "--seed", "5"], "held-out scenes start at"),
    (["eval-detector", "no/such/model.onnx"], "model not found"),
    (["eval-detector", "--images", "0"], "must be greater than 0"),
    (["eval-detector", "--view", "top"], "invalid choice: 'top'"),
    (["train-detector", "--input", "300x200"], "multiples of 16"),
])
def test_bad_options_are_one_line_and_exit_2(capsys, argv, message):
    from app.cli_train import main

    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err


def test_train_detector_without_torch_says_how_to_get_it(capsys, monkeypatch):
    import sys

    from app.cli_train import main

    monkeypatch.setitem(sys.modules, "torch", None)  # import torch raises ImportError
    assert main(["train-detector", "--images", "2"]) == 2
    assert "pip install -e '.[train]'" in capsys.readouterr().err

