"""One clock (issue 23): recordings of live runs are stamped in ROS time — wall-clock nanoseconds
since the epoch — and say so in their metadata; ``--fast`` runs say their clock is simulated."""
from __future__ import annotations

import io
import time
from pathlib import Path

from app.headless import run_headless
from core.record import topics as tp
from core.session import SessionOptions

NS = 1_000_000_000


def bag_info(folder: Path) -> dict:
    from ruamel.yaml import YAML

    return YAML(typ="safe").load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


def left_image_stamps_ns(folder: Path) -> list[int]:
    from mcap_ros2.reader import read_ros2_messages

    mcap = next(Path(folder).glob("*.mcap"))
    return [m.ros_msg.header.stamp.sec * NS + m.ros_msg.header.stamp.nanosec
            for m in read_ros2_messages(str(mcap)) if m.channel.topic == tp.CAMERA_LEFT_IMAGE]


def test_a_live_recording_starts_at_the_wall_clock_and_says_its_clock_is_ros_time(tmp_path):
    path = tmp_path / "live"
    before = time.time()
    code = run_headless(SessionOptions(camera="sim"), 1.0, True, out=io.StringIO(), err=io.StringIO(), record=str(path))
    after = time.time()
    assert code == 0
    info = bag_info(path)
    start_s = info["starting_time"]["nanoseconds_since_epoch"] / NS
    assert before - 1.0 <= start_s <= after + 1.0, (before, start_s, after)
    assert info["custom_data"]["deskarm_clock"] == tp.CLOCK_ROS
    stamps = left_image_stamps_ns(path)
    assert stamps and all(before - 1.0 <= s / NS <= after + 1.0 for s in stamps), (before, stamps[:3], after)


def test_a_fast_run_says_its_clock_is_simulated_in_the_metadata(tmp_path):
    path = tmp_path / "fast"
    code = run_headless(SessionOptions(camera="sim", simulated_clock=True), 2.0, True, out=io.StringIO(),
                        err=io.StringIO(), record=str(path))
    assert code == 0
    info = bag_info(path)
    assert info["custom_data"]["deskarm_clock"] == tp.CLOCK_SIMULATED
    assert "simulated" in info["custom_data"]["deskarm_clock_meaning"]
    assert info["starting_time"]["nanoseconds_since_epoch"] < 60 * NS  # its own seconds, not 1970 + uptime


def test_ros_epoch_is_fixed_per_clock_and_zero_for_a_simulated_one():
    from core.clock import SimClock, WallClock

    wall = WallClock()
    e = tp.ros_epoch(wall)
    assert abs((wall.now() + e) - time.time()) < 0.5
    assert tp.ros_epoch(wall) == e  # the same offset for every later stamp of this clock
    assert tp.ros_epoch(SimClock(5.0)) == 0.0
    assert tp.clock_kind(wall) == tp.CLOCK_ROS and tp.clock_kind(SimClock()) == tp.CLOCK_SIMULATED
