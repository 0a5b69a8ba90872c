"""The markers a user configures (core/vision/markers.py): the file, its errors, the session's
fallbacks, and AprilTag dictionaries detected and triangulated by the stereo perception."""
from __future__ import annotations

import textwrap
from pathlib import Path

import cv2
import numpy as np
import pytest

from core.messages import StereoFrame
from core.sim.rig import SimRig
from core.vision.markers import (
    MarkersConfig,
    MarkersError,
    MarkerSpec,
    default_markers,
    default_markers_path,
    load_markers,
    markers_for_session,
    markers_to_toml,
)
from core.vision.perception import (
    ARUCO_DICTIONARIES,
    StereoMarkerPerception,
    dictionary_size,
    make_detector,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "resources" / "markers.example.toml"
VALID = """\
dictionary = "DICT_APRILTAG_36h11"
side_m = 0.04

[places]
bin = [0.15, 0.05, 0.02]
shelf = [-0.1, 0.2, 0.1]

[[marker]]
id = 23
name = "cup A"
action = "pick_place"
place = "bin"

[[marker]]
id = 586
name = "pen"
action = "point"

[[marker]]
id = 0
"""


def write(tmp_path: Path, text: str, name: str = "markers.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def error_of(tmp_path: Path, text: str) -> str:
    path = write(tmp_path, text)
    with pytest.raises(MarkersError) as info:
        load_markers(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), f"the message names the file: {message}"
    return message[len(f"{path}: "):]


# --- a valid file ---------------------------------------------------------------------------


def test_a_valid_file_gives_its_dictionary_markers_and_places(tmp_path):
    config = load_markers(write(tmp_path, VALID))
    assert config.dictionary == "DICT_APRILTAG_36h11"
    assert config.side_m == 0.04
    assert config.ids == (23, 586, 0)
    assert config.marker(23) == MarkerSpec(23, "cup A", "pick_place", "bin")
    assert config.marker(586).action == "point" and config.marker(586).place is None
    assert config.marker(0).name == "marker 0" and config.marker(0).action == "follow"
    assert config.place_of(23) == (0.15, 0.05, 0.02)
    assert config.place_of(586) is None and config.marker(99) is None
    assert config.name_of(99) == "marker 99"
    assert config.places == {"bin": (0.15, 0.05, 0.02), "shelf": (-0.1, 0.2, 0.1)}
    assert config.source == str(tmp_path / "markers.toml")


def test_a_config_written_and_read_back_is_equal(tmp_path):
    config = load_markers(write(tmp_path, VALID))
    again = load_markers(write(tmp_path, markers_to_toml(config), "again.toml"))
    assert again == config
    defaults = load_markers(write(tmp_path, markers_to_toml(default_markers()), "defaults.toml"))
    assert defaults == default_markers()


def test_the_example_file_loads_and_matches_the_simulated_desk():
    config = load_markers(EXAMPLE)
    assert config.dictionary == "DICT_6X6_250" and config.ids == (23, 50)
    assert config.marker(23).action == "pick_place" and config.place_of(23) is not None


def test_defaults_are_todays_markers():
    config = default_markers()
    assert config.dictionary == "DICT_6X6_250" and config.side_m == 0.03
    assert config.ids == (23, 50)
    assert [m.name for m in config.markers] == ["marker 23", "marker 50"]
    assert {m.action for m in config.markers} == {"follow"}
    assert config.summary() == "2 markers (23, 50), DICT_6X6_250, 30 mm"


def test_an_upper_case_apriltag_alias_is_read_as_its_family_name(tmp_path):
    config = load_markers(write(tmp_path, 'dictionary = "DICT_APRILTAG_25H9"\n[[marker]]\nid = 34\n'))
    assert config.dictionary == "DICT_APRILTAG_25h9"


# --- bad files: one message naming the file, the key and what was expected ------------------


def test_an_unknown_dictionary_lists_the_valid_ones(tmp_path):
    message = error_of(tmp_path, 'dictionary = "DICT_9X9_7"\n[[marker]]\nid = 1\n')
    assert message.startswith("dictionary = 'DICT_9X9_7' is unknown; expected one of DICT_4X4_50, ")
    for name in ("DICT_7X7_1000", "DICT_ARUCO_ORIGINAL", "DICT_ARUCO_MIP_36h12", "DICT_APRILTAG_16h5",
                 "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10", "DICT_APRILTAG_36h11"):
        assert name in message


def test_an_id_outside_the_dictionary_names_its_range(tmp_path):
    message = error_of(tmp_path, 'dictionary = "DICT_APRILTAG_25h9"\n[[marker]]\nid = 3\n[[marker]]\nid = 35\n')
    assert message == "marker[1].id = 35 is outside 0…34 (DICT_APRILTAG_25h9 has 35 markers)"
    assert error_of(tmp_path, "[[marker]]\nid = -1\n") == "marker[0].id = -1 must be 0 or more"


def test_a_duplicate_id_names_both_entries(tmp_path):
    message = error_of(tmp_path, "[[marker]]\nid = 23\n[[marker]]\nid = 50\n[[marker]]\nid = 23\n")
    assert message == "marker[2].id = 23 is used twice (marker[0])"


def test_an_unknown_action_lists_the_actions(tmp_path):
    message = error_of(tmp_path, '[[marker]]\nid = 23\naction = "grab"\n')
    assert message == "marker[0].action = 'grab' is unknown; expected one of follow, point, pick_place"


def test_an_unknown_place_lists_the_places(tmp_path):
    message = error_of(tmp_path, '[places]\nbin = [0.1, 0.1, 0.0]\n'
                                 '[[marker]]\nid = 23\naction = "pick_place"\nplace = "box"\n')
    assert message == "marker[0].place = 'box' is not a place; expected one of [places]: bin"
    message = error_of(tmp_path, '[[marker]]\nid = 23\naction = "pick_place"\nplace = "box"\n')
    assert message == "marker[0].place = 'box' is not a place; expected one of [places]: none: add a [places] table"


def test_pick_place_without_a_place_says_what_to_add(tmp_path):
    message = error_of(tmp_path, '[[marker]]\nid = 23\naction = "pick_place"\n')
    assert message == 'marker[0].action = "pick_place" needs place = "NAME", one of the [places] table\'s names'


@pytest.mark.parametrize("text, expected", [
    ('colour = "red"\n[[marker]]\nid = 1\n', "unknown key colour; expected one of dictionary, side_m, places, marker"),
    ("[[markers]]\nid = 1\n", ("unknown key markers (the array of tables is [[marker]], singular); "
                               "expected one of dictionary, side_m, places, marker")),
    ('[[marker]]\nid = 1\nlabel = "x"\n', "unknown key marker[0].label; expected one of id, name, action, place"),
])
def test_an_unknown_key_is_named_with_the_expected_ones(tmp_path, text, expected):
    assert error_of(tmp_path, text) == expected


@pytest.mark.parametrize("text, expected", [
    ("side_m = 3\n[[marker]]\nid = 1\n", "side_m = 3 is outside 0.005…0.5 m — the side is in metres (3 cm = 0.03)"),
    ('side_m = "3 cm"\n[[marker]]\nid = 1\n', "side_m = '3 cm' must be a number of metres, got a string"),
    ("[[marker]]\nid = 2.5\n", "marker[0].id = 2.5 must be a whole number, got a decimal number"),
    ("[[marker]]\nname = \"cup\"\n", "missing key marker[0].id (the marker's number in DICT_6X6_250)"),
    ("[[marker]]\nid = 1\nname = 7\n", "marker[0].name = 7 must be a string, got a whole number"),
    ("[places]\nbin = [1, 2]\n[[marker]]\nid = 1\n", "places.bin = [1, 2] must be [x, y, z] in metres (robot_base)"),
    ("[places]\nbin = [15, 0, 0]\n[[marker]]\nid = 1\n",
     "places.bin x = 15 is outside ±2 m — places are in metres (15 cm = 0.15)"),
    ('dictionary = "DICT_4X4_50"\n', "no [[marker]] entries — add at least one (id = 23, name = \"cup A\")"),
    ("marker = 5\n", "marker must be an array of tables ([[marker]]), got a whole number"),
    ("dictionary = \n", None),  # invalid TOML: the parser's own message follows
])
def test_other_bad_values_name_the_key_and_the_fix(tmp_path, text, expected):
    message = error_of(tmp_path, text)
    if expected is None:
        assert message.startswith("invalid TOML: ")
    else:
        assert message == expected


def test_a_missing_or_unreadable_file_says_so(tmp_path):
    with pytest.raises(MarkersError, match=r"nope\.toml: no such file — check the path"):
        load_markers(tmp_path / "nope.toml")
    with pytest.raises(MarkersError, match="is a folder, expected a .toml file"):
        load_markers(tmp_path)
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe dictionary")
    with pytest.raises(MarkersError, match="not UTF-8 text"):
        load_markers(tmp_path / "bin.toml")


def test_a_config_built_in_code_is_validated_too():
    with pytest.raises(MarkersError, match=r"^marker\[1\]\.id = 50 is used twice \(marker\[0\]\)$"):
        MarkersConfig(markers=(MarkerSpec(50), MarkerSpec(50)))
    with pytest.raises(MarkersError, match=r"^marker 7: action = 'fly' is unknown"):
        MarkerSpec(7, action="fly")
    with pytest.raises(ValueError):  # MarkersError is a ValueError: callers catching that keep working
        MarkersConfig(dictionary="DICT_4X4_50", markers=(MarkerSpec(50),))


# --- which file a session uses ---------------------------------------------------------------


def test_a_session_without_a_file_uses_the_defaults_silently():
    assert not default_markers_path().exists()
    assert default_markers_path().name == "markers.toml"
    assert markers_for_session(None) == (default_markers(), None)


def test_a_session_uses_the_config_folder_file(tmp_path):
    path = default_markers_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        path.write_text(VALID, encoding="utf-8")
        config, note = markers_for_session(None)
        assert config.ids == (23, 586, 0) and note is None
        path.write_text("[[marker]]\nid = 23\n[[marker]]\nid = 23\n", encoding="utf-8")
        config, note = markers_for_session(None)
        assert config == default_markers()
        assert note == (f"{path}: marker[1].id = 23 is used twice (marker[0]) — using the built-in "
                        "markers (23, 50, DICT_6X6_250) until the file is fixed")
    finally:
        path.unlink(missing_ok=True)


def test_a_session_given_a_path_raises_its_errors(tmp_path):
    good = write(tmp_path, VALID, "good.toml")
    assert markers_for_session(str(good)) == (load_markers(good), None)
    bad = write(tmp_path, '[[marker]]\nid = 23\naction = "grab"\n', "bad.toml")
    with pytest.raises(MarkersError, match=r"bad\.toml: marker\[0\]\.action = 'grab' is unknown"):
        markers_for_session(str(bad))
    with pytest.raises(MarkersError, match="no such file"):
        markers_for_session(str(tmp_path / "missing.toml"))


# --- dictionaries -----------------------------------------------------------------------------


def test_every_predefined_opencv_dictionary_is_offered_once():
    opencv = {getattr(cv2.aruco, n) for n in dir(cv2.aruco) if n.startswith("DICT_")}
    assert sorted(ARUCO_DICTIONARIES.values()) == sorted(opencv)
    for name in ("DICT_4X4_50", "DICT_7X7_1000", "DICT_ARUCO_ORIGINAL", "DICT_ARUCO_MIP_36h12",
                 "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10", "DICT_APRILTAG_36h11"):
        assert name in ARUCO_DICTIONARIES
        make_detector(name)
    assert dictionary_size("DICT_APRILTAG_36h11") == 587 and dictionary_size("DICT_APRILTAG_25h9") == 35
    with pytest.raises(ValueError, match="unknown ArUco dictionary 'DICT_9X9_7'; valid: DICT_4X4_50"):
        make_detector("DICT_9X9_7")


def stereo_pair_with_marker(rig: SimRig, dictionary: str, marker_id: int, centre, side_m: float):
    """A synthetic stereo pair of one printed marker lying flat on a grey desk (robot_base)."""
    cells = cv2.aruco.getPredefinedDictionary(ARUCO_DICTIONARIES[dictionary]).markerSize + 2
    px_per_cell = 24
    marker = cv2.aruco.generateImageMarker(
        cv2.aruco.getPredefinedDictionary(ARUCO_DICTIONARIES[dictionary]), marker_id, cells * px_per_cell, borderBits=1)
    quiet = px_per_cell  # generateImageMarker draws no white margin: one cell of paper
    paper = cv2.copyMakeBorder(marker, quiet, quiet, quiet, quiet, cv2.BORDER_CONSTANT, value=255)
    n = paper.shape[0]
    half = side_m / 2 * n / marker.shape[0]  # the paper's half side, m
    cx, cy, cz = centre
    # texture corners TL, TR, BR, BL on the desk: texture x along -robot x and y along +robot y, as
    # the rig (looking at the arm from across the desk) sees them unmirrored
    paper_base = np.array([[cx + half, cy - half, cz], [cx - half, cy - half, cz],
                           [cx - half, cy + half, cz], [cx + half, cy + half, cz]])
    src = np.float32([[0, 0], [n, 0], [n, n], [0, n]]) - 0.5  # pixel centres are at whole numbers
    images = []
    for side in ("left", "right"):
        dst = np.float32(rig.project(side, paper_base))
        H = cv2.getPerspectiveTransform(src, dst)
        desk = np.full((rig.size[1], rig.size[0]), 150, np.uint8)
        warped = cv2.warpPerspective(paper, H, rig.size, flags=cv2.INTER_AREA, borderValue=0)
        mask = cv2.warpPerspective(np.full_like(paper, 255), H, rig.size, flags=cv2.INTER_AREA, borderValue=0)
        grey = (desk.astype(np.float32) * (255 - mask) + warped.astype(np.float32) * mask) / 255
        images.append(cv2.cvtColor(np.clip(grey + 0.5, 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR))
    return images


@pytest.mark.parametrize("dictionary, marker_id", [("DICT_APRILTAG_36h11", 586), ("DICT_APRILTAG_25h9", 23),
                                                   ("DICT_APRILTAG_16h5", 7), ("DICT_ARUCO_MIP_36h12", 200)])
def test_an_apriltag_marker_is_detected_in_both_views_and_triangulated(dictionary, marker_id):
    rig = SimRig()
    centre = (0.03, 0.12, 0.0)  # robot_base, m
    left, right = stereo_pair_with_marker(rig, dictionary, marker_id, centre, side_m=0.04)
    config = MarkersConfig(dictionary=dictionary, side_m=0.04, markers=(MarkerSpec(marker_id, "tag"),))
    perception = StereoMarkerPerception(rig.calibration(), rig.base_T_camera, marker_ids=config.ids,
                                        dictionary=config.dictionary)
    result = perception.process(StereoFrame(seq=1, t=0.0, left=left, right=right))
    obs = result.marker(marker_id)
    assert obs is not None and obs.found, f"{dictionary} {marker_id} not found: {result.markers}"
    assert len(obs.left_corners) == 4 and len(obs.right_corners) == 4
    error_mm = np.linalg.norm(np.subtract(obs.base_p_centre, centre)) * 1e3
    assert error_mm < 1.0, f"{dictionary}: centre {obs.base_p_centre} is {error_mm:.2f} mm from {centre}"
    # the default dictionary does not see it: the dictionary really chose the detector
    other = StereoMarkerPerception(rig.calibration(), rig.base_T_camera, marker_ids=config.ids)
    assert not other.process(StereoFrame(seq=1, t=0.0, left=left, right=right)).marker(marker_id).found
