"""``deskarm detect`` on image files: text and JSON output, unreadable files, bad detectors."""
from __future__ import annotations

import json

import cv2
import pytest

from app.cli import main
from tests.detect.test_detectors import MARKER_ID, RED_BALL, YELLOW_BLOB, scene


@pytest.fixture(scope="module")
def image_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("detect") / "desk.png"
    cv2.imwrite(str(path), scene())
    return str(path)


def test_json_lists_markers_with_corners_and_colour_blobs(image_path, capsys):
    assert main(["detect", image_path, "--detector", "aruco,hsv", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["detectors"] == ["aruco", "hsv"]
    (image,) = out["images"]
    assert (image["path"], image["width"], image["height"]) == (image_path, 640, 480)
    marker = image["detections"][0]
    assert (marker["kind"], marker["label"], marker["score"]) == ("marker", str(MARKER_ID), 1.0)
    assert len(marker["corners"]) == 4
    colours = [d for d in image["detections"] if d["kind"] == "colour"]
    assert [d["label"] for d in colours] == ["yellow", "red", "blue"]
    assert abs(colours[0]["centre_px"][0] - YELLOW_BLOB[0][0]) < 1.5
    assert set(colours[0]) == {"kind", "label", "score", "box", "centre_px", "radius_px"}


def test_a_colour_option_replaces_the_default_colours_and_adds_hsv(image_path, capsys):
    assert main(["detect", image_path, "--detector", "circles", "--colour", "ball=172,120,70,8,255,255", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["detectors"] == ["circles", "hsv"]
    blobs = [d for d in out["images"][0]["detections"] if d["kind"] == "colour"]
    assert [d["label"] for d in blobs] == ["ball"]
    assert abs(blobs[0]["centre_px"][1] - RED_BALL[0][1]) < 1.5
    assert any(d["kind"] == "circle" for d in out["images"][0]["detections"])


def test_text_output_names_the_image_and_each_detection(image_path, capsys):
    assert main(["detect", image_path]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"{image_path} (640x480): 4 detections"
    assert out[1].split()[:2] == ["marker", str(MARKER_ID)] and "corners" in out[1]
    assert out[2].split()[:2] == ["colour", "yellow"] and "radius" in out[2]


def test_an_unreadable_image_is_one_line_naming_it_and_exit_1(image_path, tmp_path, capsys):
    bad = tmp_path / "notes.png"
    bad.write_text("not an image")
    assert main(["detect", str(bad), image_path, "--json"]) == 1
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and str(bad) in captured.err and "cannot read the image" in captured.err
    assert [i["path"] for i in json.loads(captured.out)["images"]] == [image_path]  # the good one still ran


@pytest.mark.parametrize("argv, message", [
    (["--detector", "aruco,yolo"], "unknown detector 'yolo'; valid: aruco, hsv, circles, charuco, diamond, desk, onnx:PATH"),
    (["--detector", ""], "no detector given"),
    (["--colour", "red=1,2,3"], "is not NAME=HLO,SLO,VLO,HHI,SHI,VHI"),
    (["--colour", "red=1,2,3,4,300,6"], "s_hi = 300 is outside the allowed range 0…255"),
    (["--dictionary", "DICT_9X9"], "unknown ArUco dictionary 'DICT_9X9'"),
])
def test_a_bad_detector_or_option_is_one_line_and_exit_2(image_path, argv, message, capsys):
    assert main(["detect", image_path, *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("deskarm detect: ") and message in err, err
