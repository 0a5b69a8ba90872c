"""The twin draws only the arm that moved (issue 28, a Pi 4 core's budget; pytest-qt, offscreen):
while the commanded arm follows a jittering target and the measured arm holds still, the
measured chain and its joint dots are not set again — and the twin looks exactly like a twin
given the same arms at once.
"""
from __future__ import annotations

import numpy as np
import pytest
from PySide6 import QtWidgets

import widgets  # noqa: F401  (sets pyqtgraph's row-major image order)
from widgets.arm_twin import ArmTwin

CHAIN = np.array([[0, 0, 0], [0, 0, 0.0662], [0.05, 0.05, 0.15], [0.1, 0.1, 0.1]])
LEVELS = ["ok", "warn", "limit"]


def drain() -> None:
    for _ in range(3):
        QtWidgets.QApplication.processEvents()


@pytest.fixture
def make_twin(qtbot):
    made = []

    def make() -> ArmTwin:
        twin = ArmTwin()
        qtbot.addWidget(twin)
        twin.resize(440, 200)
        twin.show()
        qtbot.waitExposed(twin)
        made.append(twin)
        return twin

    yield make
    for twin in made:
        twin.close()


def count_calls(monkeypatch, obj, name: str) -> list:
    calls = []
    original = getattr(obj, name)
    monkeypatch.setattr(obj, name, lambda *a, **k: (calls.append(a), original(*a, **k))[1])
    return calls


def test_the_measured_arm_holding_still_is_not_set_again_while_the_commanded_arm_moves(monkeypatch, make_twin):
    twin, fresh = make_twin(), make_twin()
    twin.set_arm(CHAIN, CHAIN)
    twin.set_joint_levels(LEVELS)
    drain()
    sets = []
    for view in (twin._top, twin._side):
        for item in (view.measured.curve, view.measured.scatter, view.joints):
            sets.append(count_calls(monkeypatch, item, "setData"))
    commanded = count_calls(monkeypatch, twin._top.commanded, "setData")
    rng = np.random.default_rng(3)
    for _ in range(5):  # the commanded arm jitters in the plane of the arm (the azimuth stays)
        twin.set_arm(CHAIN + np.r_[0.0, 0.0, 1.0] * rng.normal(0.0, 0.002, (4, 1)), CHAIN.copy())
        drain()
    assert len(commanded) == 5
    assert [len(c) for c in sets] == [0] * len(sets)
    last = CHAIN + (0.0, 0.0, 0.004)
    twin.set_arm(last, CHAIN.copy())
    fresh.set_arm(last, CHAIN)
    fresh.set_joint_levels(LEVELS)
    drain()
    assert twin.grab().toImage() == fresh.grab().toImage()
    twin.set_arm(last, CHAIN + 0.01)  # the measured arm moves (in both views): drawn where it is
    fresh.set_arm(last, CHAIN + 0.01)
    drain()
    assert all(len(c) == 1 for c in sets)
    assert twin.grab().toImage() == fresh.grab().toImage()


def test_the_twins_marker_labels_follow_their_markers_without_a_transform_check_per_repaint(monkeypatch, make_twin):
    """pyqtgraph's TextItem asks for its transform at every repaint of its scene; the twin's
    marker labels follow the view's scale when it changes instead — and draw the same pixels as
    a fresh twin's."""
    from widgets._pyqtgraph import pg

    asked = []
    original = pg.TextItem.updateTransform
    monkeypatch.setattr(pg.TextItem, "updateTransform",
                        lambda self, *a, **k: (asked.append(self), original(self, *a, **k))[1])
    twin, fresh = make_twin(), make_twin()
    markers = {23: np.array([0.031, 0.152, 0.0]), 7: np.array([0.05, 0.15, 0.0])}
    twin.set_markers(markers)
    drain()
    twin.grab()
    asked.clear()
    moved = {23: np.array([0.036, 0.152, 0.0]), 7: np.array([0.05, 0.16, 0.0])}
    twin.set_markers(moved)  # the labels move with their markers
    image = twin.grab().toImage()
    assert asked == []
    fresh.set_markers(moved)
    drain()
    assert image == fresh.grab().toImage()
    twin.resize(380, 300)  # another scale: the labels follow it
    fresh.resize(380, 300)
    drain()
    assert len(asked) > 0
    assert twin.grab().toImage() == fresh.grab().toImage()
