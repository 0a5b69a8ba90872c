"""Per-class score thresholds: below its class's threshold a detection is *unsure*.

An unsure object is still shown (grey in the camera views, "unsure" in its label) but nothing
acts on it: OBJECT mode's targeting skips it and a tap on it does not follow it. A detector's own
minimum score (a learned detector's "Confidence", the circles' "Edge support") still decides what
is reported at all; the thresholds here sit above it.

Defaults: a learned detector's classes (kind "object") LEARNED_DEFAULT — a calibrated score, 0.5
means an even chance; other kinds (colour blobs, circles, markers) 0: their scores are shape
measures that their own settings already gate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

__all__ = ["ClassThresholds", "LEARNED_DEFAULT", "LEARNED_KIND"]

LEARNED_DEFAULT = 0.5  # a learned detector's class without its own threshold
LEARNED_KIND = "object"  # Detection.kind of the learned (ONNX) detectors


def _check(name: str, value) -> float:
    v = float(value)
    if not (0.0 <= v <= 1.0) or math.isnan(v):
        raise ValueError(f"score threshold {name} = {value!r} is outside 0…1")
    return v


@dataclass(frozen=True)
class ClassThresholds:
    """Score thresholds by class label, with defaults by detector kind (see the module docstring)."""

    per_class: Mapping[str, float] = field(default_factory=dict)  # label -> threshold 0…1
    learned_default: float = LEARNED_DEFAULT  # labels of kind "object" without their own threshold
    other_default: float = 0.0  # every other kind's labels without their own threshold

    def __post_init__(self) -> None:
        object.__setattr__(self, "per_class", {str(k): _check(repr(k), v) for k, v in dict(self.per_class).items()})
        object.__setattr__(self, "learned_default", _check("learned_default", self.learned_default))
        object.__setattr__(self, "other_default", _check("other_default", self.other_default))

    def threshold(self, kind: str, label: str) -> float:
        """The threshold of ``label`` (a class of a detector of ``kind``)."""
        if label in self.per_class:
            return self.per_class[label]
        return self.learned_default if kind == LEARNED_KIND else self.other_default

    def is_sure(self, observation) -> bool:
        """True when ``observation`` (anything with ``kind``, ``label`` and ``score``: a Detection,
        an ObjectObservation) scores at least its class's threshold."""
        return float(observation.score) >= self.threshold(str(observation.kind), str(observation.label))

    def with_class(self, label: str, value: float) -> "ClassThresholds":
        """A copy with ``label``'s own threshold set to ``value``."""
        return ClassThresholds({**self.per_class, str(label): value}, self.learned_default, self.other_default)
