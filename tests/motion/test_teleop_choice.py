"""Which teleop controller TELEOP mode gets (core.motion.teleop_choice): the keyboard or a hand
source, the target box presets an arm offers, the start in TELEOP mode, the plain-words hint.
The window's teleop feature only asks these. No Qt."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from core.kinematics import build_kinematics, load_profile
from core.motion.jog import JogTeleopSource
from core.motion.teleop import COMMON_TARGET_BOX, Box, TeleopController, reachable_target_box
from core.motion.teleop_choice import (
    KEYBOARD_SOURCE,
    default_source,
    starts_in_teleop,
    target_box_presets,
    teleop_controller_for,
    teleop_hint,
)

PROFILE = load_profile("desk_rrr")
KIN = build_kinematics(PROFILE)
MARGIN_M = 0.02


def test_the_keyboard_gets_a_jog_source_starting_at_the_commanded_tool_point():
    q = tuple(float(v) + 0.1 for v in PROFILE.q_home)
    source = teleop_controller_for(KEYBOARD_SOURCE, PROFILE, KIN, MARGIN_M, q_commanded=q)
    assert isinstance(source, JogTeleopSource) and source.jogger.desk_margin_m == MARGIN_M
    assert source.jogger.base_p_target == pytest.approx(tuple(KIN.fk(q)), abs=1e-6)


def test_the_keyboard_without_a_command_starts_at_home():
    source = teleop_controller_for(KEYBOARD_SOURCE, PROFILE, KIN, MARGIN_M)
    assert source.jogger.base_p_target == pytest.approx(tuple(KIN.fk(PROFILE.q_home)), abs=1e-6)


def test_a_hand_source_gets_a_teleop_controller_in_the_box_given_or_the_arms_own():
    made = []

    def factory(spec):
        made.append(spec)
        return SimpleNamespace(name=spec, reset=lambda: None)

    box = Box((-0.02, 0.1, 0.05), (0.02, 0.13, 0.08))
    controller = teleop_controller_for("marker:23", PROFILE, KIN, MARGIN_M, box=box, source_factory=factory)
    assert isinstance(controller, TeleopController) and made == ["marker:23"]
    assert controller.target_box == box
    default = teleop_controller_for("marker:7", PROFILE, KIN, MARGIN_M, source_factory=factory)
    assert default.target_box == reachable_target_box(KIN, MARGIN_M)


def test_a_source_that_cannot_be_made_raises_its_error():
    def factory(spec):
        raise ValueError(f"{spec}: no such source")

    with pytest.raises(ValueError, match="no such source"):
        teleop_controller_for("pose:/nowhere.onnx", PROFILE, KIN, MARGIN_M, source_factory=factory)


def test_the_presets_start_with_the_common_box_and_its_half_and_differ_for_the_delta():
    presets, problem = target_box_presets(KIN, MARGIN_M)
    names = [name for name, _ in presets]
    assert problem == "" and names[:2] == ["Every arm reaches", "Half size"]
    common = dict(presets)["Every arm reaches"]
    assert common == reachable_target_box(KIN, MARGIN_M, box=Box(*COMMON_TARGET_BOX))
    delta, _ = target_box_presets(build_kinematics(load_profile("delta")), MARGIN_M)
    assert delta[0][0] == "This arm's"


def test_an_arm_that_reaches_no_box_gets_no_presets_and_the_reason():
    class Nowhere:
        def ik(self, p, q0=None):
            raise ValueError("unreachable")

    presets, problem = target_box_presets(SimpleNamespace(ik=Nowhere().ik, kind="rrr"), MARGIN_M)
    assert presets == [] and problem


def test_the_default_source_is_the_chosen_one_else_the_first_marker():
    assert default_source("hsv:green", (23, 50)) == "hsv:green"
    assert default_source(None, (23, 50)) == "marker:23"
    assert default_source("", (7,)) == "marker:7"


def test_a_session_starts_in_teleop_only_when_an_option_gave_it_a_controller():
    options = SimpleNamespace(teleop_source=None, scenario="teleop")
    assert starts_in_teleop(options, object())
    assert not starts_in_teleop(options, None)
    assert starts_in_teleop(SimpleNamespace(teleop_source="marker:23", scenario="static"), object())
    assert not starts_in_teleop(SimpleNamespace(teleop_source=None, scenario="static"), object())


def test_the_hint_says_why_a_simulated_scene_without_a_hand_waits_and_nothing_otherwise():
    assert "--scenario teleop" in teleop_hint(True, "static", "marker:23")
    assert teleop_hint(True, "static", KEYBOARD_SOURCE) == ""
    assert teleop_hint(True, "teleop", "marker:23") == ""
    assert teleop_hint(False, None, "marker:23") == ""
