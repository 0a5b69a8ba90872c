"""Where deskarm keeps a user's files: the config and cache folders (``DESKARM_HOME`` overrides)."""
from __future__ import annotations

import os
from pathlib import Path


def user_dir(kind: str) -> Path:
    """Per-user config or cache folder (``DESKARM_HOME`` overrides, e.g. in tests)."""
    root = os.environ.get("DESKARM_HOME")
    if root:
        return Path(root) / kind
    import platformdirs

    if kind == "config":
        return Path(platformdirs.user_config_dir("deskarm"))
    return Path(platformdirs.user_cache_dir("deskarm"))
