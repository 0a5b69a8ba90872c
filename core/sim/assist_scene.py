"""The assistive view's simulated desk: a lift panel that answers the arm.

``AssistPanelScene`` is a still lift panel and a door handle (placed as a trial of ``deskarm
assist-trials`` places them) whose buttons react like a lift's: the button the tool tip pushes is
held down as far as the tip goes (its travel at most), and once pushed half its travel its ring
lights for ``LIT_S`` — the lift registered the call, which the user sees in the hand camera. With
``passing_hand`` the ``panel`` scenario's hand comes by now and then (a person reaching in), so
the loop meets a hidden target as on a real desk.

``PressFeedbackCamera`` wraps the ``SimHandCamera``: every image it renders first tells the scene
where the tool tip is (the camera's own pose and shake), so nothing else in the loop changes.
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from core.sim.scenarios import DoorHandle, Panel, PanelScenario, Scenario, SceneState

LIT_S = 3.0  # a registered call's ring stays lit this long (s)


class AssistPanelScene(Scenario):
    """See the module docstring. ``panel``: where the panel lies (its ``lit``/``pressed`` are
    managed here); ``handle``: the door handle beside it (or None)."""

    name = "assist-panel"

    def __init__(self, panel: Panel, handle: Optional[DoorHandle] = None, passing_hand: bool = False):
        super().__init__((), 0)
        self.base_panel = Panel(panel.x, panel.y, yaw=panel.yaw)
        self.handle = handle
        self.passing_hand = bool(passing_hand)
        self._hand_source = PanelScenario((), 0) if passing_hand else None
        self.pressed: tuple[int, ...] = ()
        self.pressed_depth_m = 0.0
        self._lit_until: dict[int, float] = {}
        self.calls: list[tuple[float, int]] = []  # (time, button) of every registered press

    def panel(self, t: float = 0.0) -> Panel:
        lit = tuple(sorted(n for n, until in self._lit_until.items() if t < until))
        p = self.base_panel
        return Panel(p.x, p.y, yaw=p.yaw, lit=lit, pressed=self.pressed)

    def feel(self, tool_tip: Sequence[float], t: float) -> None:
        """The tool tip is at ``tool_tip`` (robot_base, m) at time t: a button under it is pushed
        down by how far the tip is below its top face; half its travel registers the call."""
        tip = np.asarray(tool_tip, dtype=float)
        p = self.base_panel
        self.pressed, self.pressed_depth_m = (), 0.0
        for n in p.BUTTONS:
            top = np.array(p.button_centre(n))
            depth = top[2] - tip[2]
            if depth <= 0.0 or depth > p.press_depth_m + 0.02:
                continue  # above the button, or far below it (not on it)
            if np.hypot(*(tip[:2] - top[:2])) <= p.button_radius_m:
                self.pressed, self.pressed_depth_m = (n,), float(min(depth, p.press_depth_m))
                if depth >= p.press_depth_m / 2 and t >= self._lit_until.get(n, -np.inf):
                    self._lit_until[n] = t + LIT_S
                    self.calls.append((float(t), n))
                break

    def state(self, t: float) -> SceneState:
        hand = self._hand_source.hand_at(t) if self._hand_source is not None else None
        return SceneState(panels=(self.panel(t),), handles=() if self.handle is None else (self.handle,),
                          hands=() if hand is None else (hand,))


class PressFeedbackCamera:
    """A ``SimHandCamera`` whose ``render`` first lets ``scene`` feel the tool tip (see the module
    docstring); everything else is the wrapped camera's."""

    def __init__(self, camera, scene: AssistPanelScene):
        self._camera = camera
        self.scene = scene

    def render(self, q: Sequence[float], t: float):
        self.scene.feel(self._camera.base_T_tool(q, t)[:3, 3], t)
        return self._camera.render(q, t)

    def __getattr__(self, name):
        return getattr(self._camera, name)
