"""Are the system libraries Qt needs installed? Names the one apt command that installs them.

The PySide6 wheels bundle Qt itself but not the system libraries under it (GLib, EGL/GL, X11
and xcb, xkbcommon, fontconfig, freetype, D-Bus). A desktop system has them; a minimal one
(Raspberry Pi OS Lite, a Debian container, a fresh arm64 root file system) lacks them, and
the window then fails with ``ImportError: libglib-2.0.so.0: cannot open shared object file``
— one library at a time. ``missing_libraries()`` asks ``ldd`` about every Qt library and
platform plugin deskarm loads at once, and ``apt_command()`` maps what is missing to Debian
package names (Bookworm's and Trixie's ``t64`` names differ).

``python -m app.qt_libraries`` (run by ``make setup``) prints nothing when all is there, else
what is missing and the command; ``--install`` runs that command when it may (as root, with
apt-get), e.g. in a container. No Qt is imported here: this runs where Qt cannot load.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Iterable, Optional

# the Qt libraries and plugins the window loads (Core/Gui/Widgets/OpenGL, the desktop plugins)
QT_LIBRARIES = ("libQt6Core.so.6", "libQt6Gui.so.6", "libQt6Widgets.so.6", "libQt6OpenGL.so.6",
                "libQt6DBus.so.6", "libQt6XcbQpa.so.6")
QT_PLUGINS = ("platforms/libqxcb.so", "platforms/libqoffscreen.so", "xcbglintegrations/libqxcb-glx-integration.so")

# soname -> Debian package (Bookworm name, Trixie name when it differs: the 64-bit time_t rename)
DEBIAN_PACKAGES: dict[str, tuple[str, Optional[str]]] = {
    "libglib-2.0.so.0": ("libglib2.0-0", "libglib2.0-0t64"),
    "libgthread-2.0.so.0": ("libglib2.0-0", "libglib2.0-0t64"),
    "libgobject-2.0.so.0": ("libglib2.0-0", "libglib2.0-0t64"),
    "libEGL.so.1": ("libegl1", None),
    "libGL.so.1": ("libgl1", None),
    "libGLX.so.0": ("libglx0", None),
    "libOpenGL.so.0": ("libopengl0", None),
    "libGLdispatch.so.0": ("libglvnd0", None),
    "libX11.so.6": ("libx11-6", None),
    "libX11-xcb.so.1": ("libx11-xcb1", None),
    "libxcb.so.1": ("libxcb1", None),
    "libxcb-cursor.so.0": ("libxcb-cursor0", None),
    "libxcb-icccm.so.4": ("libxcb-icccm4", None),
    "libxcb-image.so.0": ("libxcb-image0", None),
    "libxcb-keysyms.so.1": ("libxcb-keysyms1", None),
    "libxcb-randr.so.0": ("libxcb-randr0", None),
    "libxcb-render-util.so.0": ("libxcb-render-util0", None),
    "libxcb-render.so.0": ("libxcb-render0", None),
    "libxcb-shape.so.0": ("libxcb-shape0", None),
    "libxcb-shm.so.0": ("libxcb-shm0", None),
    "libxcb-sync.so.1": ("libxcb-sync1", None),
    "libxcb-util.so.1": ("libxcb-util1", None),
    "libxcb-xfixes.so.0": ("libxcb-xfixes0", None),
    "libxcb-xkb.so.1": ("libxcb-xkb1", None),
    "libxcb-glx.so.0": ("libxcb-glx0", None),
    "libxkbcommon.so.0": ("libxkbcommon0", None),
    "libxkbcommon-x11.so.0": ("libxkbcommon-x11-0", None),
    "libdbus-1.so.3": ("libdbus-1-3", None),
    "libfontconfig.so.1": ("libfontconfig1", None),
    "libfreetype.so.6": ("libfreetype6", None),
    "libpng16.so.16": ("libpng16-16", "libpng16-16t64"),
    "libz.so.1": ("zlib1g", None),
    "libzstd.so.1": ("libzstd1", None),
    "libSM.so.6": ("libsm6", None),
    "libICE.so.6": ("libice6", "libice6"),
}
FONT_PACKAGE = "fonts-dejavu-core"  # Qt draws no text without at least one font
FONT_FOLDERS = ("/usr/share/fonts", "/usr/local/share/fonts")


def pyside_folder() -> Optional[Path]:
    """The installed PySide6 package folder (found without importing it), or None."""
    spec = importlib.util.find_spec("PySide6")
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(list(spec.submodule_search_locations)[0])


def qt_files(folder: Path) -> list[Path]:
    """The Qt libraries and plugins of a PySide6 folder that exist in this wheel."""
    names = [folder / "Qt" / "lib" / n for n in QT_LIBRARIES] + [folder / "Qt" / "plugins" / n for n in QT_PLUGINS]
    return [p for p in names if p.exists()]


def not_found_in_ldd(output: str) -> list[str]:
    """The sonames ``ldd`` reports as ``not found``."""
    missing = []
    for line in output.splitlines():
        name, _, where = line.strip().partition("=>")
        if "not found" in where:
            missing.append(name.strip())
    return missing


def missing_libraries(folder: Optional[Path] = None, ldd: str = "ldd") -> list[str]:
    """Every system library a Qt library or plugin of the installed PySide6 needs and cannot find."""
    folder = folder or pyside_folder()
    if folder is None or shutil.which(ldd) is None:
        return []
    env = dict(os.environ)
    env["LD_LIBRARY_PATH"] = str(folder / "Qt" / "lib")  # the bundled Qt libraries find each other
    missing: list[str] = []
    for path in qt_files(folder):
        run = subprocess.run([ldd, str(path)], capture_output=True, text=True, env=env, check=False)
        for name in not_found_in_ldd(run.stdout):
            if name not in missing and not name.startswith("libQt6") and not name.startswith("libpyside6"):
                missing.append(name)
    return missing


def has_fonts(folders: Iterable[str] = FONT_FOLDERS) -> bool:
    for folder in folders:
        for _root, _dirs, files in os.walk(folder):
            if any(f.lower().endswith((".ttf", ".otf", ".pcf.gz", ".pfb", ".ttc")) for f in files):
                return True
    return False


def debian_codename(os_release: str = "/etc/os-release") -> str:
    try:
        text = Path(os_release).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""
    for line in text.splitlines():
        if line.startswith("VERSION_CODENAME="):
            return line.split("=", 1)[1].strip().strip('"')
    return ""


def packages_for(missing: Iterable[str], codename: str, fonts: bool = True) -> tuple[list[str], list[str]]:
    """(Debian packages, sonames with no known package) for the missing libraries."""
    t64 = codename not in ("", "bullseye", "bookworm", "focal", "jammy")
    packages: list[str] = []
    unknown: list[str] = []
    for name in missing:
        entry = DEBIAN_PACKAGES.get(name)
        if entry is None:
            unknown.append(name)
            continue
        package = entry[1] if (t64 and entry[1]) else entry[0]
        if package not in packages:
            packages.append(package)
    if not fonts and FONT_PACKAGE not in packages:
        packages.append(FONT_PACKAGE)
    return packages, unknown


def apt_command(packages: Iterable[str], root: bool) -> str:
    return ("" if root else "sudo ") + "apt-get install -y " + " ".join(packages)


def report(missing: list[str], fonts: bool, codename: str, root: bool) -> str:
    """Empty when Qt has everything; else what is missing and the one command that installs it."""
    if not missing and fonts:
        return ""
    packages, unknown = packages_for(missing, codename, fonts)
    lines = []
    if missing:
        lines.append("deskarm: the window needs system libraries Qt cannot find: " + ", ".join(missing) + ".")
    if not fonts:
        lines.append("deskarm: no fonts are installed: Qt would draw no text.")
    if packages:
        lines.append("Install them with:  " + apt_command(packages, root))
    if unknown:
        lines.append("No Debian package known here for " + ", ".join(unknown) + ": search with apt-file.")
    lines.append("The headless runner (deskarm --headless) works without them.")
    return "\n".join(lines)


def problem() -> str:
    """The report for this machine (empty when the window can start)."""
    if not sys.platform.startswith("linux") or pyside_folder() is None:
        return ""  # no Qt installed (no wheel for this system): make run says so and runs headless
    return report(missing_libraries(), has_fonts(), debian_codename(), os.geteuid() == 0)


NO_QT_WHEEL = (
    "deskarm: the window needs PySide6 (Qt for Python) 6.8.0.2 or newer, and it is not installed: "
    "PySide6 has no wheel for this system (32-bit ARM systems such as 32-bit Raspberry Pi OS have none; "
    "this system's C library: glibc {glibc}). A 64-bit OS runs the window (Raspberry Pi OS Bookworm or "
    "Trixie, 64-bit). Here: deskarm --headless runs the loop, and deskarm serve shares this desk so that "
    "the window runs on another machine (deskarm --remote).")


def glibc_version() -> str:
    import platform

    name, version = platform.libc_ver()
    return version if name == "glibc" and version else "another C library"


def import_failure_text(exc: ImportError) -> str:
    """What to tell the user when importing Qt failed ("" when the error is not about Qt):
    a missing system library under Qt, or no PySide6 at all (no wheel for this system)."""
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] in ("PySide6", "shiboken6"):
        return NO_QT_WHEEL.format(glibc=glibc_version())
    if "cannot open shared object file" not in str(exc):
        return ""
    return problem() or f"deskarm: {exc}"


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.qt_libraries", description=__doc__.split("\n")[0])
    parser.add_argument("--install", action="store_true",
                        help="install what is missing with apt-get (only as root, when apt-get exists)")
    args = parser.parse_args(argv)
    text = problem()
    if not text:
        return 0
    print(text, file=sys.stderr)
    if args.install and os.geteuid() == 0 and shutil.which("apt-get"):
        packages, _unknown = packages_for(missing_libraries(), debian_codename(), has_fonts())
        if packages:
            env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
            subprocess.run(["apt-get", "update", "-q"], check=False, env=env)
            done = subprocess.run(["apt-get", "install", "-y", "-q", "--no-install-recommends", *packages],
                                  check=False, env=env)
            if done.returncode == 0 and not problem():
                print("deskarm: installed " + " ".join(packages), file=sys.stderr)
                return 0
    return 1


if __name__ == "__main__":
    sys.exit(main())
