"""The help feature on its own (app/features/help.py): F1's dialog is made once and announced (it
has STOP); holding Reset settings resets the preferences and says where the old file went."""
from pathlib import Path

import pytest
from PySide6 import QtCore, QtWidgets

from app.features.help import HelpFeature
from feature_rig import TIMEOUT_MS

LEFT = QtCore.Qt.MouseButton.LeftButton


class Preferences:
    """Stands in for WindowPreferences (a window's): its file and its reset."""

    path = Path("/tmp/deskarm-test/preferences.toml")

    def __init__(self):
        self.resets = 0

    def reset(self) -> bool:
        self.resets += 1
        return True


@pytest.fixture
def help_feature(qtbot, session):
    host = QtWidgets.QWidget()
    qtbot.addWidget(host)
    feature = HelpFeature(session, Preferences(), host)
    feature.kept, feature.notes, feature.made = host, [], []  # kept: qtbot holds it weakly
    feature.sigNote.connect(feature.notes.append)
    feature.sigDialogMade.connect(feature.made.append)
    yield feature
    if feature.help_dialog is not None:
        feature.help_dialog.close()


def test_help_is_made_once_and_announced(qtbot, help_feature):
    dialog = help_feature.show_help()
    qtbot.waitExposed(dialog)
    assert help_feature.show_help() is dialog and help_feature.made == [dialog]


def test_holding_reset_resets_the_settings_and_says_so(qtbot, help_feature):
    dialog = help_feature.show_help()
    qtbot.waitExposed(dialog)
    button = dialog.reset_button
    qtbot.mouseClick(button, LEFT)  # a tap is no hold
    assert help_feature.preferences.resets == 0
    with qtbot.waitSignal(dialog.sigResetRequested, timeout=TIMEOUT_MS):
        qtbot.mousePress(button, LEFT)
    qtbot.mouseRelease(button, LEFT)
    assert help_feature.preferences.resets == 1 and "preferences.toml.bak" in help_feature.notes[-1]
