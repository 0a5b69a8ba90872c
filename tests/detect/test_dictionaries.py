"""Marker dictionaries: ``deskarm detect`` takes markers.toml's; custom dictionary files (OpenCV's
``Dictionary.writeDictionary`` YAML) work wherever a dictionary name does, and a bad one is one
clear message naming the file."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main
from core.vision.markers import MarkersError, load_markers
from core.vision.perception import dictionary_size

DATA = Path(__file__).resolve().parents[1] / "data"
PHOTO = str(DATA / "charuco" / "charuco_8x6_legacy_left01.jpg")  # real photo, markers 0…23 of DICT_4X4_50
# a custom dictionary: DICT_4X4_50's markers 5, 3 and 17, as ids 0, 1 and 2
CUSTOM_FROM = (5, 3, 17)


def write_custom_dictionary(path: Path) -> Path:
    base = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    custom = cv2.aruco.Dictionary(base.bytesList[list(CUSTOM_FROM)], 4, 1)
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    custom.writeDictionary(storage)
    storage.release()
    return path


def _marker_ids(capsys, argv) -> list[int]:
    assert main(["detect", PHOTO, "--detector", "aruco", "--json", *argv]) == 0
    detections = json.loads(capsys.readouterr().out)["images"][0]["detections"]
    return sorted(int(d["label"]) for d in detections if d["kind"] == "marker")


@pytest.fixture
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path / "home"))
    (tmp_path / "home" / "config").mkdir(parents=True)
    return tmp_path / "home" / "config"


def test_detect_uses_the_dictionary_of_markers_toml(home, capsys):
    assert _marker_ids(capsys, []) == []  # the default DICT_6X6_250 sees none of the 4x4 markers
    (home / "markers.toml").write_text('dictionary = "DICT_4X4_50"\n[[marker]]\nid = 3\n')
    assert _marker_ids(capsys, []) == list(range(24))
    assert _marker_ids(capsys, ["--dictionary", "DICT_6X6_250"]) == []  # the option still wins


def test_detect_takes_the_dictionary_of_an_explicit_markers_file(home, tmp_path, capsys):
    markers = tmp_path / "mine.toml"
    markers.write_text('dictionary = "DICT_4X4_50"\n[[marker]]\nid = 3\n')
    assert _marker_ids(capsys, ["--markers", str(markers)]) == list(range(24))


def test_a_broken_markers_toml_is_said_and_detect_goes_on_with_the_default(home, capsys):
    (home / "markers.toml").write_text('dictionary = "DICT_9X9_1"\n')
    assert main(["detect", PHOTO, "--detector", "aruco"]) == 0
    captured = capsys.readouterr()
    assert "markers.toml: dictionary = 'DICT_9X9_1' is unknown" in captured.err
    assert "0 detections" in captured.out


def test_a_custom_dictionary_file_works_with_the_dictionary_option(home, tmp_path, capsys):
    path = write_custom_dictionary(tmp_path / "custom.yml")
    assert dictionary_size(str(path)) == 3
    assert _marker_ids(capsys, ["--dictionary", str(path)]) == [0, 1, 2]  # renumbered: it is this file's


def test_a_custom_dictionary_file_works_in_markers_toml_relative_to_it(home, capsys):
    write_custom_dictionary(home / "custom.yml")
    (home / "markers.toml").write_text('dictionary = "custom.yml"\n[[marker]]\nid = 2\nname = "cup"\n')
    config = load_markers(home / "markers.toml")
    assert Path(config.dictionary) == home / "custom.yml"
    assert _marker_ids(capsys, []) == [0, 1, 2]
    (home / "markers.toml").write_text('dictionary = "custom.yml"\n[[marker]]\nid = 3\n')
    with pytest.raises(MarkersError, match=r"marker\[0\]\.id = 3 .*custom\.yml has 3 markers"):
        load_markers(home / "markers.toml")


def test_a_custom_dictionary_works_for_the_diamond_too(tmp_path, capsys):
    base = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    custom = cv2.aruco.Dictionary(base.bytesList[[8, 7, 6, 5]], 4, 1)  # the diamond's 5,6,7,8 as 3,2,1,0
    storage = cv2.FileStorage(str(tmp_path / "d.json"), cv2.FILE_STORAGE_WRITE)
    custom.writeDictionary(storage)
    storage.release()
    photo = str(DATA / "charuco" / "diamond_5_6_7_8_left03.jpg")
    assert main(["detect", photo, "--detector", "diamond", "--dictionary", str(tmp_path / "d.json"), "--json"]) == 0
    [diamond] = json.loads(capsys.readouterr().out)["images"][0]["detections"]
    assert diamond["label"] == "3,2,1,0"


BAD_FILES = {
    "not_a_dictionary.yml": ("%YAML:1.0\nfoo: 1\n", "not an ArUco dictionary"),
    "unparsable.yml": ("garbage {{{ :\n\t", "not a YAML, JSON or XML file OpenCV can read"),
    "short_marker.yml": ('%YAML:1.0\nnmarkers: 1\nmarkersize: 4\nmaxCorrectionBits: 1\nmarker_0: "101"\n',
                         "marker_0 = '101' must be 16 bits"),
    "missing_marker.yml": ('%YAML:1.0\nnmarkers: 2\nmarkersize: 4\nmaxCorrectionBits: 1\n'
                           'marker_0: "1011010100110010"\n', "not an ArUco dictionary"),
    "empty.json": ("", "dictionary file"),
}


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_a_bad_dictionary_file_is_one_line_naming_it_and_exit_2(name, tmp_path, capsys):
    text, message = BAD_FILES[name]
    path = tmp_path / name
    path.write_text(text)
    assert main(["detect", PHOTO, "--detector", "aruco", "--dictionary", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and message in err, err
    assert "Traceback" not in err


def test_a_missing_dictionary_file_is_named(tmp_path, capsys):
    assert main(["detect", PHOTO, "--dictionary", str(tmp_path / "nope.yml")]) == 2
    err = capsys.readouterr().err
    assert f"dictionary file {tmp_path / 'nope.yml'}: No such file or directory" in err


def test_a_bad_dictionary_file_in_markers_toml_names_both_files(home):
    (home / "broken.yml").write_text("foo: 1\n")
    (home / "markers.toml").write_text('dictionary = "broken.yml"\n[[marker]]\nid = 1\n')
    with pytest.raises(MarkersError) as info:
        load_markers(home / "markers.toml")
    text = str(info.value)
    assert "markers.toml: dictionary = 'broken.yml'" in text and str(home / "broken.yml") in text


def test_a_changed_dictionary_file_is_read_again(tmp_path):
    from core.vision.perception import read_dictionary_file

    path = write_custom_dictionary(tmp_path / "c.yml")
    assert read_dictionary_file(path).bytesList.shape[0] == 3
    base = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    cv2.aruco.Dictionary(base.bytesList[:5], 4, 1).writeDictionary(storage)
    storage.release()
    assert np.asarray(read_dictionary_file(path).bytesList).shape[0] == 5


def test_a_charuco_board_of_a_custom_dictionary_file_calibrates_like_a_named_one(tmp_path):
    """The calibration's ChArUco boards take a dictionary file as well (issue 25 item 15:
    custom dictionaries were refused everywhere): the board from DICT_4X4_50's first 12 markers,
    written as a file, is found in OpenCV's own picture of it, corner for corner."""
    from core.vision.stereo_calibration import BoardError, CharucoSpec, detect_board

    base = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    path = tmp_path / "my_board_dict.yml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    cv2.aruco.Dictionary(base.bytesList[:12], 4, 1).writeDictionary(storage)
    storage.release()
    named = CharucoSpec(6, 4, 0.03, 0.022, "DICT_4X4_50")
    custom = CharucoSpec(6, 4, 0.03, 0.022, str(path))
    picture = named.cv_board().generateImage((600, 400), marginSize=40, borderBits=1)
    picture = cv2.cvtColor(picture, cv2.COLOR_GRAY2BGR)
    a, b = detect_board(picture, named), detect_board(picture, custom)
    assert a.ok and b.ok and b.n == named.n_corners, (a.reason, b.reason)
    assert np.array_equal(a.ids, b.ids) and np.allclose(a.corners, b.corners, atol=1e-3)
    with pytest.raises(BoardError, match="needs 15 markers but .* has only 12"):  # too small for a 6x5 board
        CharucoSpec(6, 5, 0.03, 0.022, str(path))
