"""Shared test set-up: user folders in a temp dir, Qt offscreen."""
import os

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")


@pytest.fixture(autouse=True)
def _deskarm_home(tmp_path_factory, monkeypatch):
    """Config and cache folders of a throw-away user, so tests never touch the real ones."""
    monkeypatch.setenv("DESKARM_HOME", str(tmp_path_factory.getbasetemp() / "deskarm_home"))
