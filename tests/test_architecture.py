"""The house rules of DESIGN.md, kept by import-linter (contracts in pyproject.toml):
app -> widgets -> core; core imports no Qt or pyqtgraph; devices and kinematics never import
vision or the simulated desk; no import cycle between the wings of core or inside a wing; the
window's features (app/features/) never import each other nor the window."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


def lint_imports(tree: Path) -> subprocess.CompletedProcess:
    """Run lint-imports on ``tree`` (a copy of the packages and pyproject.toml, or the repo)."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    return subprocess.run([str(LINT), "--no-cache", "--no-logo"], cwd=tree, env=env, capture_output=True,
                          text=True, timeout=300)


def copy_of_the_packages(dest: Path) -> Path:
    for package in ("core", "app", "widgets"):
        shutil.copytree(ROOT / package, dest / package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", dest / "pyproject.toml")
    return dest


def add_line(path: Path, line: str) -> None:
    path.write_text(path.read_text() + "\n" + line + "\n")


@pytest.fixture(scope="module")
def lint_tool():
    if not LINT.exists():
        pytest.fail(f"{LINT} missing: import-linter belongs to the test extra (pip install -e '.[test]')")
    return LINT


def test_the_import_contracts_hold(lint_tool):
    done = lint_imports(ROOT)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "0 broken" in done.stdout


@pytest.mark.parametrize("module, bad_import, broken", [
    ("core/devices/sim_arm.py", "from PySide6 import QtCore", "core imports no Qt and no pyqtgraph"),
    ("core/kinematics/rrr.py", "import pyqtgraph", "core imports no Qt and no pyqtgraph"),
    ("core/devices/serial_v1.py", "from core.vision import calibration",
     "devices and kinematics never import vision or the simulated desk"),
    ("core/kinematics/delta.py", "import core.sim.rig", "devices and kinematics never import vision or the simulated desk"),
    ("core/vision/cameras.py", "from core.sim.camera import SimStereoCamera",
     "vision and motion never import the simulated desk"),
    ("core/motion/control.py", "import widgets.status", "app -> widgets -> core"),
    ("core/kinematics/base.py", "from core.kinematics import profile", "no import cycles"),
    ("core/motion/safety.py", "from core.devices import bridge", "no import cycles"),
    ("app/features/jog.py", "from app.features.teleop import TeleopFeature",
     "the window's features never import each other"),
    ("app/features/markers.py", "import app.features.target", "the window's features never import each other"),
    ("app/features/status.py", "from app import gui", "features never import the window that composes them"),
])
def test_a_bad_import_breaks_its_contract(tmp_path, lint_tool, module, bad_import, broken):
    tree = copy_of_the_packages(tmp_path)
    add_line(tree / module, bad_import)
    done = lint_imports(tree)
    assert done.returncode != 0, f"{bad_import} in {module} passed:\n{done.stdout}"
    broken_lines = [line for line in done.stdout.splitlines() if line.endswith("BROKEN")]
    assert any(line.startswith(broken) for line in broken_lines), done.stdout


def import_cycles(package: str) -> list[list[str]]:
    """Strongly connected components of more than one module in ``package``'s import graph
    (every import, also inside functions; TYPE_CHECKING-only imports left out), package
    ``__init__`` modules included."""
    import grimp

    graph = grimp.build_graph(package, exclude_type_checking_imports=True, cache_dir=None)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(module: str) -> None:  # Tarjan's algorithm
        index[module] = low[module] = len(index)
        stack.append(module)
        on_stack.add(module)
        for imported in graph.find_modules_directly_imported_by(module):
            if imported not in index:
                visit(imported)
                low[module] = min(low[module], low[imported])
            elif imported in on_stack:
                low[module] = min(low[module], index[imported])
        if low[module] == index[module]:
            component = []
            while True:
                m = stack.pop()
                on_stack.discard(m)
                component.append(m)
                if m == module:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for module in sorted(graph.modules):
        if module not in index:
            visit(module)
    return cycles


def test_no_module_of_core_takes_part_in_an_import_cycle():
    """Also cycles through a package's __init__ (which the sibling contract does not see)."""
    assert import_cycles("core") == []


def test_the_cycle_finder_finds_a_cycle(tmp_path, monkeypatch):
    pkg = tmp_path / "cyc"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from cyc import a\n")
    (pkg / "a.py").write_text("def f():\n    from cyc import b\n")
    (pkg / "b.py").write_text("import cyc\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert import_cycles("cyc") == [["cyc", "cyc.a", "cyc.b"]]
