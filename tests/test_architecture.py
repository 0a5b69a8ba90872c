"""The folder split of DESIGN.md: core/ never imports Qt, pyqtgraph, app or widgets."""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = ("PySide6", "PyQt5", "PyQt6", "shiboken6", "pyqtgraph", "superqt", "qtpy", "app", "widgets")


def imported_modules(path: Path):
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.lineno, node.module


def test_core_imports_no_qt_app_or_widgets():
    offenders = []
    files = sorted((ROOT / "core").rglob("*.py"))
    assert len(files) > 5, "core/ should hold the computing modules"
    for path in files:
        for lineno, module in imported_modules(path):
            if module.split(".")[0] in FORBIDDEN:
                offenders.append(f"{path.relative_to(ROOT)}:{lineno} imports {module}")
    assert not offenders, "core/ must stay Qt-free:\n" + "\n".join(offenders)


def test_the_scan_catches_a_forbidden_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import os\nfrom PySide6 import QtCore\n")
    assert [m for _, m in imported_modules(bad)] == ["os", "PySide6"]


def test_widgets_do_not_import_app():
    for path in sorted((ROOT / "widgets").rglob("*.py")):
        for lineno, module in imported_modules(path):
            assert module.split(".")[0] != "app", f"{path.name}:{lineno} imports {module}"
