"""The eye-in-hand camera and the range sensor on the simulated desk."""
import math

import numpy as np
import pytest

from core.kinematics.clik import ClikKinematics
from core.kinematics.profile import load_profile
from core.sim.desk import SimDesk
from core.sim.hand_camera import HandCameraConfig, SimHandCamera
from core.sim.range_sensor import RangeSensorConfig, SimRangeSensor
from core.sim.rig import SimRig
from core.sim.scenarios import PanelScenario


@pytest.fixture(scope="module")
def camera():
    desk = SimDesk(SimRig(), "panel")
    return SimHandCamera(desk, ClikKinematics(load_profile("assistive_5dof")))


def test_a_button_lands_where_projection_says(camera):
    q = camera.kinematics.q_home
    frame = camera.render(q, 3.0, boxes=True)
    assert frame.image.shape == (480, 640, 3)
    panel = PanelScenario((23, 50)).panel_at(3.0)
    for n in (1, 5, 9):
        uv, _ = camera.project(frame.base_T_camera, np.array([panel.button_centre(n)]))
        box = frame.boxes[panel.button_truth_id(n)]
        assert np.hypot(*(np.array(box.centre) - uv[0])) < 2.0
        _, Z = camera.project(frame.base_T_camera, np.array([panel.button_centre(n)]))
        assert box.width == pytest.approx(2 * 525.0 * panel.button_radius_m / Z[0], rel=0.15)


def test_vibration_shakes_camera_and_tool_together():
    desk = SimDesk(SimRig(), "panel")
    cam = SimHandCamera(desk, ClikKinematics(load_profile("assistive_5dof")), HandCameraConfig(vibration=True))
    q = cam.kinematics.q_home
    a, b = cam.base_T_camera(q, 0.0), cam.base_T_camera(q, 0.05)
    assert 1e-5 < np.linalg.norm(a[:3, 3] - b[:3, 3]) < 0.003
    np.testing.assert_allclose(np.linalg.inv(a) @ cam.base_T_tool(q, 0.0), cam.camera_T_tool, atol=1e-12)


def _looking_down(x, y, z):
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])  # z down
    T[:3, 3] = (x, y, z)
    return T


def test_range_sensor_sees_the_nearest_surface_in_its_cone():
    desk = SimDesk(SimRig(), "panel")
    clean = RangeSensorConfig(noise_sigma_m=0.0, dropout_probability=0.0)
    sensor = SimRangeSensor(desk, clean)
    assert sensor.measure(_looking_down(0.3, 0.4, 0.5), 0.0) == pytest.approx(0.5)  # bare desk
    panel = PanelScenario((23,)).panel_at(0.0)
    bx, by, bz = panel.button_centre(5)
    assert sensor.measure(_looking_down(bx, by, 0.3), 0.0) == pytest.approx(0.3 - bz, abs=1e-6)
    # beside the panel: the axis hits the desk, but the cone's edge catches the plate
    edge_x = panel.x - panel.width_m / 2 - 0.01  # the −x side (the handle is on the +x side)
    r = sensor.true_range(_looking_down(edge_x, panel.y, 0.3), 0.0)
    assert 0.3 - panel.button_top_z(1) - 1e-6 <= r <= 0.3 - panel.top_z + 1e-6  # the plate or a button
    narrow = SimRangeSensor(desk, RangeSensorConfig(cone_deg=1.0, noise_sigma_m=0.0, dropout_probability=0.0))
    assert narrow.true_range(_looking_down(edge_x, panel.y, 0.3), 0.0) == pytest.approx(0.3, abs=1e-6)


def test_range_sensor_limits_and_dropouts():
    desk = SimDesk(SimRig(), "static")
    sensor = SimRangeSensor(desk, RangeSensorConfig(noise_sigma_m=0.0, dropout_probability=0.0))
    assert sensor.measure(_looking_down(0.3, 0.4, 0.01), 0.0) is None  # nearer than 2 cm
    assert sensor.measure(_looking_down(0.3, 0.4, 4.5), 0.0) is None  # beyond 4 m
    up = np.eye(4)
    up[:3, 3] = (0, 0, 0.3)
    assert sensor.measure(up, 0.0) is None  # looking at the horizon: no echo
    lossy = SimRangeSensor(desk, RangeSensorConfig(dropout_probability=0.3, noise_sigma_m=0.002), seed=3)
    readings = [lossy.measure(_looking_down(0.3, 0.4, 0.5), 0.0) for _ in range(400)]
    missing = sum(r is None for r in readings) / len(readings)
    assert 0.2 < missing < 0.4
    values = np.array([r for r in readings if r is not None])
    assert abs(values.mean() - 0.5) < 0.001 and 0.001 < values.std() < 0.003
