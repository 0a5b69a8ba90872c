#!/usr/bin/env bash
# Which wheels each platform deskarm runs on gets, resolved from the package index for that target
# (uv pip compile --python-platform: markers and wheel tags are evaluated for the target, not this
# machine; --only-binary: nothing would be compiled on the Pi).
#   bash tests/arm64/resolve_wheels.sh            # every platform, the Qt, vision and robotics wheels
#   bash tests/arm64/resolve_wheels.sh --all      # every pinned package
set -euo pipefail
cd "$(dirname "$0")/../.."
UV=${UV:-.venv/bin/uv}
FILTER='pyside6|shiboken6|opencv|numpy|^pin==|eclipse-zenoh|pyqtgraph|superqt|rosbags'
[ "${1:-}" = --all ] && FILTER='.'
for target in "aarch64-manylinux_2_36 3.11 Raspberry Pi OS Bookworm (64-bit)" \
              "aarch64-manylinux_2_40 3.13 Raspberry Pi OS Trixie (64-bit)" \
              "aarch64-manylinux_2_39 3.12 Ubuntu 24.04 arm64" \
              "x86_64-manylinux_2_36 3.11 Debian Bookworm x86-64 (this machine)"; do
    set -- $target
    platform=$1 python=$2; shift 2
    echo "== $* — $platform, Python $python"
    "$UV" pip compile pyproject.toml --extra test --python-platform "$platform" --python-version "$python" \
        --only-binary :all: --no-header --no-annotate -q | grep -iE "$FILTER" | sed 's/^/   /'
    if ! "$UV" pip compile pyproject.toml --python-platform "$platform" --python-version "$python" \
            --only-binary :all: --no-header --no-annotate -q | grep -qi '^pyside6-essentials'; then
        echo "   (no PySide6: the window is not installed here — headless, serve and --remote work)"
    fi
done
