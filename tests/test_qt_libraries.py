"""The set-up's check of the system libraries Qt needs (app/qt_libraries.py), with real ldd."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from app import qt_libraries as ql

needs_tools = pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("ldd") is None,
                                 reason="needs gcc and ldd to build a library with a missing dependency")


def _fake_pyside(tmp_path: Path, missing: list[str]) -> Path:
    """A PySide6-shaped folder whose libQt6Gui.so.6 links to libraries that do not exist."""
    build = tmp_path / "build"
    build.mkdir()
    lib = tmp_path / "PySide6" / "Qt" / "lib"
    lib.mkdir(parents=True)
    links = []
    for soname in missing:  # build each dependency, link against it, then delete it
        stem = soname.split(".so")[0]
        src = build / f"{stem}.c"
        src.write_text(f"int {stem.replace('-', '_').replace('.', '_')}_x(void) {{ return 1; }}\n")
        subprocess.run(["gcc", "-shared", "-fPIC", f"-Wl,-soname,{soname}", str(src), "-o", str(build / soname)],
                       check=True)
        links.append(str(build / soname))
    (build / "gui.c").write_text("int gui(void) { return 0; }\n")
    subprocess.run(["gcc", "-shared", "-fPIC", "-Wl,--no-as-needed", str(build / "gui.c"), *links,
                    "-o", str(lib / "libQt6Gui.so.6")], check=True)
    for path in links:
        Path(path).unlink()
    return tmp_path / "PySide6"


@needs_tools
def test_every_missing_library_is_found_at_once_with_the_real_ldd(tmp_path):
    # names no system has (a real libglib is installed here, so it would be found)
    folder = _fake_pyside(tmp_path, ["libdeskarm-glib.so.0", "libdeskarm-xkb.so.0", "libdeskarm-nowhere.so.1"])
    missing = ql.missing_libraries(folder)
    assert sorted(missing) == ["libdeskarm-glib.so.0", "libdeskarm-nowhere.so.1", "libdeskarm-xkb.so.0"]


@needs_tools
def test_a_complete_folder_reports_nothing(tmp_path):
    assert ql.missing_libraries(_fake_pyside(tmp_path, [])) == []


def test_bookworm_and_trixie_get_their_own_package_names():
    missing = ["libglib-2.0.so.0", "libEGL.so.1", "libpng16.so.16", "libxcb-cursor.so.0"]
    assert ql.packages_for(missing, "bookworm")[0] == ["libglib2.0-0", "libegl1", "libpng16-16", "libxcb-cursor0"]
    assert ql.packages_for(missing, "trixie")[0] == ["libglib2.0-0t64", "libegl1", "libpng16-16t64", "libxcb-cursor0"]


def test_the_report_names_what_is_missing_and_one_command():
    text = ql.report(["libglib-2.0.so.0", "libGL.so.1", "libweird.so.3"], fonts=False, codename="bookworm", root=False)
    assert "libglib-2.0.so.0, libGL.so.1, libweird.so.3" in text
    assert "no fonts are installed" in text
    commands = [line for line in text.splitlines() if "apt-get install" in line]
    assert len(commands) == 1
    assert commands[0].endswith("sudo apt-get install -y libglib2.0-0 libgl1 fonts-dejavu-core")
    assert "libweird.so.3" in text.splitlines()[-2] and "apt-file" in text
    assert "deskarm --headless" in text
    as_root = ql.report(["libGL.so.1"], fonts=True, codename="trixie", root=True)
    assert "Install them with:  apt-get install -y libgl1" in as_root


def test_nothing_missing_says_nothing():
    assert ql.report([], fonts=True, codename="trixie", root=False) == ""


def test_this_machines_pyside_is_checked(tmp_path):
    folder = ql.pyside_folder()
    if folder is None:
        pytest.skip("no PySide6 here (no wheel for this system): nothing to check")
    assert folder is not None and (folder / "Qt" / "lib" / "libQt6Core.so.6").exists()
    assert len(ql.qt_files(folder)) >= 4  # Core, Gui, Widgets and the platform plugins really are checked


def test_codename_from_os_release(tmp_path):
    release = tmp_path / "os-release"
    release.write_text('PRETTY_NAME="Debian GNU/Linux 13 (trixie)"\nVERSION_CODENAME=trixie\n')
    assert ql.debian_codename(str(release)) == "trixie"
    assert ql.debian_codename(str(tmp_path / "none")) == ""


def test_fonts_are_found_in_a_folder_with_one(tmp_path):
    assert not ql.has_fonts([str(tmp_path)])
    (tmp_path / "truetype").mkdir()
    (tmp_path / "truetype" / "DejaVuSans.ttf").write_bytes(b"\0")
    assert ql.has_fonts([str(tmp_path)])


def test_an_import_error_for_a_missing_library_becomes_the_report(monkeypatch, capsys):
    import app.cli as cli

    def failing(argv):
        raise ImportError("libglib-2.0.so.0: cannot open shared object file: No such file or directory")

    monkeypatch.setattr(cli, "_main", failing)
    monkeypatch.setattr(ql, "problem", lambda: ql.report(["libglib-2.0.so.0"], True, "bookworm", False))
    assert cli.main([]) == 2
    err = capsys.readouterr().err
    assert "libglib-2.0.so.0" in err and "sudo apt-get install -y libglib2.0-0" in err


def test_other_import_errors_are_not_hidden(monkeypatch):
    import app.cli as cli

    def failing(argv):
        raise ImportError("No module named 'zenoh'")

    monkeypatch.setattr(cli, "_main", failing)
    with pytest.raises(ImportError, match="zenoh"):
        cli.main([])


def test_no_pyside_at_all_says_which_systems_run_the_window(monkeypatch, capsys):
    import app.cli as cli

    def failing(argv):
        raise ModuleNotFoundError("No module named 'PySide6'", name="PySide6")

    monkeypatch.setattr(cli, "_main", failing)
    monkeypatch.setattr(ql, "glibc_version", lambda: "2.36")
    assert cli.main([]) == 2
    err = capsys.readouterr().err
    assert "glibc 2.36" in err and "64-bit" in err and "deskarm --headless" in err and "--remote" in err


def test_pyproject_gives_bookworm_and_trixie_the_window_and_keeps_6_12_0_out():
    """The PySide6 requirement, evaluated for each Pi OS (tests/arm64/resolve_wheels.sh resolves the
    real wheels: Bookworm aarch64 gets 6.8.0.2, Trixie 6.11.3): it applies on 64-bit Pi OS, not on
    32-bit (no wheel exists there), allows Bookworm's newest wheel and keeps the crashing 6.12.0 out."""
    import tomllib

    from packaging.requirements import Requirement

    deps = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]["dependencies"]
    (req,) = [Requirement(d) for d in deps if d.lower().startswith("pyside6")]
    bookworm = {"platform_machine": "aarch64", "python_version": "3.11", "sys_platform": "linux"}
    trixie = {"platform_machine": "aarch64", "python_version": "3.13", "sys_platform": "linux"}
    armv7 = {"platform_machine": "armv7l", "python_version": "3.11", "sys_platform": "linux"}
    assert req.marker.evaluate(bookworm) and req.marker.evaluate(trixie) and not req.marker.evaluate(armv7)
    assert req.specifier.contains("6.8.0.2") and req.specifier.contains("6.11.3")
    assert not req.specifier.contains("6.12.0") and not req.specifier.contains("6.7.3")
