"""The assist loop with a box detector (the learned desk model): ``SizedBoxDetector`` gives each box
a radius and the physical radius it measures, runs the network on the whole image whatever the
window asked, and the loop's depth from size uses that physical radius."""
import numpy as np
import pytest

from core.detect.base import Detection
from core.motion.assist_loop import BUTTON_RING_RADIUS_M, SizedBoxDetector


class FakeBoxDetector:
    """Boxes of a button, another button and a handle; remembers how it was called."""

    name = "fake"
    names = ["button", "handle"]

    def __init__(self):
        self.calls = []

    def detect(self, image, roi=None):
        self.calls.append((id(image), roi))
        return [Detection("object", "button", 0.9, (100, 100, 40, 30), (120, 115)),
                Detection("object", "button", 0.8, (300, 200, 20, 24), (310, 212)),
                Detection("object", "handle", 0.7, (400, 50, 150, 40), (475, 70))]


def test_boxes_of_the_chosen_class_get_half_their_larger_side_as_radius():
    fake = FakeBoxDetector()
    sized = SizedBoxDetector(fake, "button", BUTTON_RING_RADIUS_M)
    found = sized.detect(np.zeros((480, 640, 3), np.uint8))
    assert [d.label for d in found] == ["button", "button"]
    assert [d.radius_px for d in found] == [20.0, 12.0]
    assert sized.known_radius_m == BUTTON_RING_RADIUS_M and sized.name == "fake:button"


def test_a_window_keeps_the_detections_centred_in_it_but_the_network_sees_the_whole_image_once():
    fake = FakeBoxDetector()
    sized = SizedBoxDetector(fake, "button", BUTTON_RING_RADIUS_M)
    image = np.zeros((480, 640, 3), np.uint8)
    inside = sized.detect(image, (250, 150, 100, 100))
    assert [d.centre_px for d in inside] == [(310.0, 212.0)]
    assert len(sized.detect(image)) == 2
    assert fake.calls == [(id(image), None)]  # never a crop (it would be enlarged to the input size), once
    sized.detect(np.zeros((480, 640, 3), np.uint8))
    assert len(fake.calls) == 2  # a new image is looked at again


def test_the_point_to_servo_on_can_sit_below_the_box_centre_by_a_share_of_its_width():
    sized = SizedBoxDetector(FakeBoxDetector(), "button", BUTTON_RING_RADIUS_M, centre_shift_of_width=0.1)
    found = sized.detect(np.zeros((480, 640, 3), np.uint8))
    assert [d.centre_px for d in found] == [(120.0, 119.0), (310.0, 214.0)]  # + 0.1 × 40 px, + 0.1 × 20 px
    assert [d.box for d in found] == [(100.0, 100.0, 40.0, 30.0), (300.0, 200.0, 20.0, 24.0)]  # boxes unchanged
    with pytest.raises(ValueError, match="centre_shift_of_width"):
        SizedBoxDetector(FakeBoxDetector(), "button", BUTTON_RING_RADIUS_M, centre_shift_of_width=0.8)


def test_a_class_the_detector_does_not_have_or_a_silly_radius_is_refused_with_the_choices():
    with pytest.raises(ValueError, match="no class 'lever'.*button, handle"):
        SizedBoxDetector(FakeBoxDetector(), "lever", 0.01)
    with pytest.raises(ValueError, match="known_radius_m"):
        SizedBoxDetector(FakeBoxDetector(), "button", 0.0)


def test_the_loop_takes_the_depth_from_the_radius_the_box_detector_says_it_measures():
    from app.cli_assist import AssistTrials

    trials = AssistTrials(detector="circles")
    loop = trials.loop
    f = trials.camera.K[0, 0]
    loop.detector = SizedBoxDetector(FakeBoxDetector(), "button", 0.011)
    image = np.full((480, 640, 3), 230, np.uint8)  # bright inside: the circle rule would say "ring"
    assert loop._depth(image, (320.0, 240.0), f * 0.011 / 0.2) == pytest.approx(0.2)
    loop.detector = SizedBoxDetector(FakeBoxDetector(), "button", 0.0122)
    assert loop._depth(image, (320.0, 240.0), f * 0.011 / 0.2) == pytest.approx(0.2 * 0.0122 / 0.011)


def test_assist_detectors_by_name():
    from app.cli_assist import ASSIST_DETECTORS, DESK_BUTTON_CENTRE_SHIFT, DESK_BUTTON_RADIUS_M, make_assist_detector

    assert ASSIST_DETECTORS == ("circles", "desk")
    circles = make_assist_detector("circles")
    assert circles.name == "circles" and not hasattr(circles, "known_radius_m")
    desk = make_assist_detector("desk")
    assert desk.label == "button" and desk.known_radius_m == DESK_BUTTON_RADIUS_M and desk.name == "desk:button"
    assert desk.centre_shift_of_width == DESK_BUTTON_CENTRE_SHIFT
    with pytest.raises(ValueError, match="unknown assist detector 'yolo'; valid: circles, desk"):
        make_assist_detector("yolo")
