"""The README's command lines name files a new user has: every input path in a fenced shell block
exists in the repository (globs match), and every command naming a shipped file runs (exit 0)."""
from __future__ import annotations

import glob
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# options whose value is something the command writes, not a file it reads
OUTPUT_OPTIONS = {"--out", "--export-ros", "--screenshot", "--record"}
# forms that name no file of the repository: devices, serial and network endpoints
NOT_FILES = re.compile(r"^(/dev/|COM\d|tcp/|udp/|[a-z0-9]+://|webcam:|gpio:|gamepad:|key:)")
PREFIXED = re.compile(r"^(urdf|onnx|folder|replay|sbs):(.+)$")  # a file behind a kind prefix
FILE_LIKE = re.compile(r"[/*]|\.(png|jpe?g|urdf|toml|ya?ml|onnx|json|mcap|xml)$", re.IGNORECASE)


def readme_commands(text: str) -> list[str]:
    """The ``deskarm`` command lines of the README's fenced sh blocks, continuation lines joined,
    comments dropped."""
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", text, re.DOTALL):
        joined = re.sub(r"\\\n\s*", " ", block)
        for line in joined.splitlines():
            line = re.sub(r"(^|\s)#.*$", "", line).strip()
            if "deskarm" in line.split(" ", 1)[0]:
                commands.append(line)
    return commands


def input_paths(command: str) -> list[str]:
    """The files a command line reads (globs kept as globs); outputs and devices left out."""
    words = shlex.split(command)[1:]
    paths = []
    for i, word in enumerate(words):
        if word.startswith("-") or (i > 0 and words[i - 1] in OUTPUT_OPTIONS):
            continue
        word = word.split("=", 1)[-1]
        prefixed = PREFIXED.match(word)
        if prefixed:
            word = prefixed.group(2)
        elif NOT_FILES.match(word) or ":" in word or "," in word:
            continue  # endpoints, NAME=ROLE switches, comma lists of values
        if NOT_FILES.match(word) or not FILE_LIKE.search(word):
            continue
        paths.append(word)
    return paths


COMMANDS = readme_commands(README.read_text(encoding="utf-8"))


def test_the_readme_has_commands_and_names_shipped_samples():
    assert len(COMMANDS) >= 10
    named = {path for command in COMMANDS for path in input_paths(command)}
    assert any(path.startswith("tests/data/") for path in named), named


@pytest.mark.parametrize("command", COMMANDS)
def test_every_file_a_readme_command_reads_is_in_the_repository(command):
    for path in input_paths(command):
        matches = glob.glob(str(ROOT / path))
        assert matches, f"README: `{command}` names {path}, which a fresh clone does not have"


def test_the_paths_the_old_readme_named_are_caught():
    for command in ("deskarm detect photo.png --json",
                    "deskarm calibrate --left 'pairs/left_*.png' --right 'pairs/right_*.png' --export-ros ros/",
                    "deskarm bench-ik --robot urdf:my_arm.urdf --tip tool0"):
        paths = input_paths(command)
        assert paths and not any(glob.glob(str(ROOT / p)) for p in paths), paths
    assert input_paths("deskarm --screenshot shot.png --camera 0,2 --bridge v2:/dev/ttyACM0") == []


SHIPPED = [c for c in COMMANDS if input_paths(c)]


@pytest.mark.parametrize("command", SHIPPED)
def test_every_readme_command_naming_a_shipped_file_runs(command, tmp_path):
    # run from a scratch folder that sees the repository's samples, so outputs land there
    for name in ("tests", "resources"):
        (tmp_path / name).symlink_to(ROOT / name)
    argv = [sys.executable, "-m", "app.cli", *shlex.split(command)[1:]]
    env = dict(os.environ, PYTHONPATH=str(ROOT), DESKARM_HOME=str(tmp_path / "home"), QT_QPA_PLATFORM="offscreen")
    done = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"`{command}` exited {done.returncode}:\n{done.stderr[-2000:]}"
    assert not (tmp_path / "home" / "config" / "calibration.yaml").exists()  # --out: nothing installed
