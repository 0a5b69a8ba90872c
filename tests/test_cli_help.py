"""``deskarm --help`` names every tool ``main`` dispatches on; ``deskarm detect --help`` every detector."""
from __future__ import annotations

import re

import pytest

from app.cli import SUBCOMMANDS, main
from core.detect.registry import detector_names


def _help(capsys, argv) -> str:
    try:  # argparse exits; a tool may catch that and return the code
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    assert code in (0, None)
    return re.sub(r"\s+", " ", capsys.readouterr().out)  # argparse wraps lines


def test_the_main_help_lists_every_subcommand_main_dispatches_on(capsys):
    text = _help(capsys, ["--help"])
    tools = text.split("tools", 1)[1]
    missing = [name for name in SUBCOMMANDS if not re.search(rf"(?<![\w-]){re.escape(name)}(?![\w-])", tools)]
    assert not missing, f"deskarm --help does not name {missing}: {tools}"
    assert {"detect", "serve", "assist-trials", "train-detector"} <= set(SUBCOMMANDS)


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_every_listed_tool_answers_its_own_help(name, capsys):
    text = _help(capsys, [name, "--help"])
    assert "usage:" in text


def test_the_detect_help_lists_every_detector_kind(capsys):
    text = _help(capsys, ["detect", "--help"])
    names = detector_names()
    assert {"desk", "charuco", "diamond"} <= set(names)
    missing = [name for name in names if name not in text]
    assert not missing, f"deskarm detect --help does not name {missing}"
