#!/usr/bin/env bash
# make check-arm64 — deskarm on an emulated Raspberry Pi OS (Debian arm64), with the README's commands.
#
# 1. A Debian arm64 root file system (default: Bookworm, glibc 2.36, Python 3.11 — what Raspberry
#    Pi OS Bookworm is built on) made with debootstrap from Debian's packages; its second stage runs
#    under qemu-user-static through binfmt_misc. Cached in $ARM64_ROOT (the first run takes ~40 min
#    of emulated package set-up; later runs reuse it).
# 2. deskarm's committed tree copied in, then the README's first command: `make run` — with no
#    display it creates .venv, installs (PySide6 resolves to the newest wheel this glibc allows),
#    reports missing Qt system libraries (a minimal system has none) and runs the headless demo.
# 3. Where PySide6 installed (Bookworm: 6.8.0.2), Qt's system libraries as the set-up's check
#    names them, then the 800x480 window offscreen: its screenshot is copied to $ROOT.window.png.
# 4. `make test` restricted to the core tests (the window tests would take hours under emulation)
#    and the firmware tests without sanitizers (ASan binaries are killed for memory under qemu-user).
#    QEMU_CPU=cortex-a76 (a Pi 5 core): with QEMU 7.2's default CPU numpy picks SME kernels that
#    QEMU computes wrongly.
# Needs root. Not in CI (too slow). Environment: ARM64_SUITE (bookworm|trixie), ARM64_ROOT, ARM64_MIRROR.
set -euo pipefail
SUITE=${ARM64_SUITE:-bookworm}
ROOT=${ARM64_ROOT:-/var/tmp/deskarm-arm64-$SUITE}
MIRROR=${ARM64_MIRROR:-http://deb.debian.org/debian}
REPO=$(cd "$(dirname "$0")/../.." && pwd)
CORE_TESTS=${ARM64_TESTS:-"tests/kinematics tests/vision tests/motion tests/devices tests/sim tests/record tests/detect tests/handeye tests/test_qt_libraries.py"}
export QEMU_CPU=${QEMU_CPU:-cortex-a76}

say() { printf 'check-arm64: %s\n' "$*" >&2; }
if [ "$(id -u)" != 0 ]; then say "needs root (debootstrap, chroot, binfmt_misc): run it with sudo"; exit 2; fi

apt_need() {  # command package…
    command -v "$1" >/dev/null 2>&1 && return 0
    say "installing ${*:2}"
    DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -q "${@:2}" >/dev/null
}
apt_need debootstrap debootstrap
apt_need qemu-aarch64-static qemu-user-static

mountpoint -q /proc/sys/fs/binfmt_misc || mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc
if [ ! -e /proc/sys/fs/binfmt_misc/qemu-aarch64 ]; then
    if command -v update-binfmts >/dev/null 2>&1 && update-binfmts --enable qemu-aarch64 2>/dev/null; then :; else
        # the ELF header of an aarch64 executable; F: the interpreter is opened now (works in a chroot)
        echo ':qemu-aarch64:M::\x7fELF\x02\x01\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x02\x00\xb7\x00:\xff\xff\xff\xff\xff\xff\xff\x00\xff\xff\xff\xff\xff\xff\xff\xff\xfe\xff\xff\xff:/usr/bin/qemu-aarch64-static:F' \
            > /proc/sys/fs/binfmt_misc/register
    fi
fi

mounted=()
cleanup() { for m in "${mounted[@]:-}"; do [ -n "$m" ] && umount -l "$m" 2>/dev/null || true; done; }
trap cleanup EXIT
mount_in() {  # type source target
    mountpoint -q "$3" && return 0
    mkdir -p "$3"
    if [ "$1" = bind ]; then mount --bind "$2" "$3"; else mount -t "$1" "$2" "$3"; fi
    mounted=("$3" "${mounted[@]:-}")
}

if [ ! -e "$ROOT/.deskarm-base" ]; then
    say "building a Debian $SUITE arm64 root file system in $ROOT (first run: about 40 minutes)"
    rm -rf "$ROOT"
    t0=$(date +%s)
    debootstrap --arch=arm64 --foreign --variant=minbase \
        --include=python3,python3-venv,make,gcc,libc6-dev,ca-certificates,git \
        "$SUITE" "$ROOT" "$MIRROR" >/dev/null
    cp /usr/bin/qemu-aarch64-static "$ROOT/usr/bin/"
    chroot "$ROOT" /debootstrap/debootstrap --second-stage >/dev/null
    touch "$ROOT/.deskarm-base"
    say "root file system ready in $(( $(date +%s) - t0 )) s"
fi

mount_in proc proc "$ROOT/proc"
mount_in sysfs sys "$ROOT/sys"
mount_in bind /dev "$ROOT/dev"
mount_in devpts devpts "$ROOT/dev/pts"
cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf"
# trust what this machine trusts (a proxy's own CA included), for pip and uv inside
cp -L /etc/ssl/certs/ca-certificates.crt "$ROOT/etc/ssl/certs/ca-certificates.crt"

say "copying deskarm's committed tree ($(git -C "$REPO" rev-parse --short HEAD))"
rm -rf "$ROOT/home/deskarm"
mkdir -p "$ROOT/home/deskarm"
git -C "$REPO" archive HEAD | tar -x -C "$ROOT/home/deskarm"

in_root() {
    chroot "$ROOT" /usr/bin/env -i HOME=/root PATH=/usr/local/bin:/usr/bin:/bin LANG=C.UTF-8 \
        SSL_CERT_FILE=/etc/ssl/certs/ca-certificates.crt PIP_CERT=/etc/ssl/certs/ca-certificates.crt \
        REQUESTS_CA_BUNDLE=/etc/ssl/certs/ca-certificates.crt PIP_DEFAULT_TIMEOUT=180 QEMU_CPU="$QEMU_CPU" /bin/bash -c "cd /home/deskarm && $1"
}
say "system: $(in_root 'uname -m; ldd --version | head -1; python3 --version' | tr '\n' ' ')"
t0=$(date +%s)
say "make run (no display: set-up, then the headless demo)"
in_root "make run"
say "make run took $(( $(date +%s) - t0 )) s"
say "PySide6 installed there: $(in_root '.venv/bin/python -c "import importlib.metadata as m
try:
    print(m.version(\"PySide6-Essentials\"))
except m.PackageNotFoundError:
    print(\"none (no wheel for this glibc: no window; headless, serve and --remote work)\")"')"
if in_root '.venv/bin/python -c "import PySide6"' 2>/dev/null; then
    # the window on this OS: the set-up's own check installs Qt's system libraries (as root), then
    # an offscreen screenshot of the 800x480 window, copied out beside the root file system
    t0=$(date +%s)
    say "Qt's system libraries (python -m app.qt_libraries --install), then the window offscreen"
    in_root ".venv/bin/python -m app.qt_libraries --install" || true
    in_root "QT_QPA_PLATFORM=offscreen .venv/bin/deskarm --size 800x480 --after 3 --screenshot /tmp/arm64-window.png"
    cp "$ROOT/tmp/arm64-window.png" "$ROOT.window.png"
    say "the window drew $ROOT.window.png in $(( $(date +%s) - t0 )) s"
fi
t0=$(date +%s)
say "make test (core and firmware tests, no sanitizers) under emulation"
in_root "make test SAN= TESTS='$CORE_TESTS'"
say "make test took $(( $(date +%s) - t0 )) s"
