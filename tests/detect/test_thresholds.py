"""Per-class score thresholds (core.detect.thresholds): what is unsure, and OBJECT mode's
targeting skipping unsure objects (no Qt)."""
from dataclasses import dataclass
from typing import Optional

import pytest

from core.clock import SimClock
from core.detect.thresholds import LEARNED_DEFAULT, ClassThresholds
from core.messages import PerceptionResult, TargetMode
from core.motion.targeting import Targeter


@dataclass(frozen=True)
class Obs:
    """The fields of ``core.detect.stereo.ObjectObservation`` the targeter and thresholds read."""

    object_id: int
    label: str
    score: float
    kind: str = "object"
    base_p: Optional[tuple] = (0.20, 0.10, 0.03)
    velocity_base: Optional[tuple] = (0.05, 0.0, 0.0)
    triangulated: bool = True


def test_learned_classes_are_unsure_below_one_half_and_other_kinds_never_by_default():
    t = ClassThresholds()
    assert t.threshold("object", "cup") == LEARNED_DEFAULT == 0.5
    assert not t.is_sure(Obs(1, "cup", 0.49)) and t.is_sure(Obs(1, "cup", 0.5))
    assert t.is_sure(Obs(2, "red", 0.05, kind="colour")) and t.is_sure(Obs(3, "circle", 0.0, kind="circle"))


def test_a_class_of_its_own_overrides_the_default_for_that_class_only():
    t = ClassThresholds().with_class("cup", 0.8).with_class("red", 0.3)
    assert not t.is_sure(Obs(1, "cup", 0.7)) and t.is_sure(Obs(1, "ball", 0.7))
    assert not t.is_sure(Obs(2, "red", 0.2, kind="colour")) and t.is_sure(Obs(2, "green", 0.2, kind="colour"))


@pytest.mark.parametrize("bad", [{"per_class": {"cup": 1.5}}, {"learned_default": -0.1},
                                 {"other_default": float("nan")}])
def test_a_threshold_outside_zero_to_one_names_itself(bad):
    with pytest.raises(ValueError, match="outside 0…1"):
        ClassThresholds(**bad)


def frame(t, *objects):
    return PerceptionResult(seq=1, t=t, markers=(), timings_ms={}, full_frame_search=False, objects=tuple(objects))


def test_object_mode_does_not_follow_an_unsure_object_until_its_threshold_is_lowered():
    clock = SimClock()
    targeter = Targeter(clock, mode=TargetMode.OBJECT)
    targeter.set_follow_object("cup")
    unsure_cup = Obs(1, "cup", 0.35)
    targeter.set_object_thresholds(ClassThresholds())
    clock.advance(0.033)
    goal = targeter.update(frame(clock.now(), unsure_cup))
    assert not goal.valid  # held: the only cup is unsure
    targeter.set_object_thresholds(ClassThresholds().with_class("cup", 0.3))
    clock.advance(0.033)
    goal = targeter.update(frame(clock.now(), unsure_cup))
    assert goal.valid and "cup" in goal.note
    with pytest.raises(TypeError, match="is_sure"):
        targeter.set_object_thresholds(0.5)
