"""Where deskarm keeps a user's files: the config and cache folders (``DESKARM_HOME`` overrides),
and the one way files are written there (whole or not at all, errors that name the path)."""
from __future__ import annotations

import errno
import os
import secrets
from pathlib import Path


def user_dir(kind: str) -> Path:
    """Per-user config, data or cache folder (``DESKARM_HOME`` overrides, e.g. in tests)."""
    root = os.environ.get("DESKARM_HOME")
    if root:
        return Path(root) / kind
    import platformdirs

    if kind == "config":
        return Path(platformdirs.user_config_dir("deskarm"))
    if kind == "data":  # files users keep (recordings)
        return Path(platformdirs.user_data_dir("deskarm"))
    return Path(platformdirs.user_cache_dir("deskarm"))


def os_error_reason(exc: OSError) -> str:
    """What went wrong, in words ("permission denied"), without the ``[Errno 13]`` prefix."""
    if isinstance(exc, PermissionError) or exc.errno in (errno.EACCES, errno.EPERM):
        return "permission denied"
    if exc.strerror:
        return exc.strerror[:1].lower() + exc.strerror[1:]
    return str(exc) or type(exc).__name__


def _user_folder_hint(path: Path) -> str:
    try:
        mine = any(path.resolve().is_relative_to(user_dir(k).resolve()) for k in ("config", "data", "cache"))
    except (OSError, RuntimeError):  # an unresolvable path is simply not one of ours
        mine = False
    return " or set DESKARM_HOME to a writable folder" if mine else " or choose another path"


def write_error(path: Path, exc: OSError) -> OSError:
    """An OSError of the same kind as ``exc`` whose message names ``path``, the reason and the fix."""
    folder = Path(path).parent
    if isinstance(exc, PermissionError) or exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        fix = f"make {folder} writable for your user{_user_folder_hint(Path(path))}"
    else:
        fix = f"check {folder}{_user_folder_hint(Path(path))}"
    error = type(exc)(f"{path}: cannot write: {os_error_reason(exc)} — {fix}")
    error.errno = exc.errno  # callers may still test the errno; str() stays the message above
    return error


def write_file_atomically(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file beside it and a rename, creating the
    folder if needed: the file is whole or unchanged. Raises an OSError naming the path and the
    fix ("…: cannot write: permission denied — make … writable …") instead of a bare ``[Errno 13]``."""
    path = Path(path)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # a unique name: two deskarm processes starting together write the same file safely
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
        with open(tmp, "xb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            try:
                tmp.unlink(missing_ok=True)
            except OSError:  # the folder refused the write: it may refuse the clean-up too
                pass
        raise write_error(path, exc) from None
    return path


class UserFileError(ValueError):
    """A user's TOML file that cannot be read; the message names the file, what is wrong and the fix."""


def read_user_toml(path: str | os.PathLike, what: str, fix: str) -> dict:
    """The tables of a user's TOML file, or UserFileError naming the file, the problem and ``fix``.

    ``what`` names the file's kind ("a hand-eye file"); ``fix`` says what to do ("run `deskarm
    calibrate-hand-eye` again"). A file that is not there raises FileNotFoundError (callers tell a
    first start apart); an unreadable, non-UTF-8, invalid or absurdly nested file (tomllib recurses
    once per nested array or inline table: a RecursionError, never a traceback) raises UserFileError.
    """
    import tomllib

    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise
    except IsADirectoryError:
        raise UserFileError(f"{path}: is a folder, expected {what} (a .toml file) — {fix}") from None
    except OSError as exc:
        raise UserFileError(f"{path}: cannot read: {os_error_reason(exc)} — {fix}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UserFileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start}) — {fix}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise UserFileError(f"{path}: not valid TOML ({exc}) — {fix}") from None
    except (RecursionError, MemoryError):
        raise UserFileError(f"{path}: nested too deeply (arrays or tables hundreds of levels inside each "
                            f"other) to be {what} — {fix}") from None
