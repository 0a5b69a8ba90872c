# deskarm — `make run` and `make test` do all the set-up on a fresh machine.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup run test test-qt-oldest bench bench-full bench-pi firmware-test clean install-desktop check-arm64

setup: $(STAMP)

# Re-install when pyproject.toml changes; uv is ~3x faster than pip when it is available. Bytecode is
# compiled at install (as pip does; uv only when asked), deskarm's own packages too (an editable
# install leaves them as source): a Pi's first start would spend seconds compiling otherwise.
$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@$(PY) -m pip install -q --upgrade pip uv >/dev/null 2>&1 || true
	@if $(VENV)/bin/uv --version >/dev/null 2>&1; then \
		VIRTUAL_ENV=$(VENV) $(VENV)/bin/uv pip install -q --compile-bytecode -e '.[test]'; \
	else \
		$(PY) -m pip install -q -e '.[test]'; \
	fi
	@$(PY) -m compileall -q app core widgets >/dev/null || true
	@$(PY) -m app.qt_libraries || true  # names the apt command when Qt's system libraries are missing
	@touch $(STAMP)

run: $(STAMP)
	@if ! $(PY) -c "import PySide6" >/dev/null 2>&1; then \
		$(PY) -c "from app.qt_libraries import NO_QT_WHEEL, glibc_version; print(NO_QT_WHEEL.format(glibc=glibc_version()))"; \
		echo "deskarm: running the headless demo instead"; \
		$(VENV)/bin/deskarm --headless --scenario cups --duration 10; \
	elif [ -n "$$DISPLAY$$WAYLAND_DISPLAY" ] || [ "$$(uname)" = Darwin ]; then \
		$(VENV)/bin/deskarm; \
	else \
		echo "deskarm: no display found (DISPLAY/WAYLAND_DISPLAY unset) — running the headless demo instead"; \
		$(VENV)/bin/deskarm --headless --scenario cups --duration 10; \
	fi

test: $(STAMP) firmware-test
	$(VENV)/bin/lint-imports --no-logo --no-cache
	QT_QPA_PLATFORM=offscreen $(PY) -m pytest -q $$($(PY) -c "import PySide6" 2>/dev/null || echo "-p no:pytest-qt") $(TESTS)

# The oldest PySide6 deskarm allows (Raspberry Pi OS Bookworm's newest wheel) in a venv of its own,
# running the tests that build the window and its panels (CI; QT_OLDEST_TESTS=tests for the whole suite).
QT_OLDEST       := 6.8.0.2
QT_OLDEST_VENV  := .venv-qt-oldest
QT_OLDEST_TESTS ?= tests/window/features tests/window/test_main_window.py tests/window/test_touch_window.py \
	tests/window/test_text_fit.py tests/window/test_no_qt_cycles.py tests/window/test_gui_thread_garbage.py \
	tests/window/test_stop_strip.py tests/window/test_physical_estop.py tests/window/test_labeled_slider.py \
	tests/window/test_assist_window.py tests/window/test_widgets.py
test-qt-oldest: $(STAMP)
	@test -x $(QT_OLDEST_VENV)/bin/python || $(PYTHON) -m venv $(QT_OLDEST_VENV)
	@if $(VENV)/bin/uv --version >/dev/null 2>&1; then \
		VIRTUAL_ENV=$(QT_OLDEST_VENV) $(VENV)/bin/uv pip install -q -e '.[test]' 'PySide6-Essentials==$(QT_OLDEST)'; \
	else \
		$(QT_OLDEST_VENV)/bin/python -m pip install -q -e '.[test]' 'PySide6-Essentials==$(QT_OLDEST)'; \
	fi
	QT_QPA_PLATFORM=offscreen $(QT_OLDEST_VENV)/bin/python -m pytest -q -p no:cacheprovider $(QT_OLDEST_TESTS)

firmware-test:
	@if [ -f firmware/Makefile ]; then $(MAKE) -s -C firmware test; fi
	@if command -v avr-gcc >/dev/null 2>&1; then $(MAKE) -s -C firmware avr; \
	else echo "firmware-test: avr-gcc not installed, ATmega328P build skipped (apt-get install gcc-avr avr-libc)"; fi

# ikpy (the IK baseline) is only needed for the bench
$(VENV)/.bench-installed: $(STAMP)
	@if $(VENV)/bin/uv --version >/dev/null 2>&1; then \
		VIRTUAL_ENV=$(VENV) $(VENV)/bin/uv pip install -q -e '.[test,bench]'; \
	else \
		$(PY) -m pip install -q -e '.[test,bench]'; \
	fi
	@touch $@

# a few minutes; bench-full takes the long runs (about 20 minutes on 2 cores)
bench: $(VENV)/.bench-installed
	QT_QPA_PLATFORM=offscreen $(PY) -m bench

bench-full: $(VENV)/.bench-installed
	QT_QPA_PLATFORM=offscreen $(PY) -m bench --full

# the loop, the 800x480 window and the assistive view held to one Raspberry Pi 4 / Pi 5 core's CPU
# time (a cgroup v1 CPU quota: needs root), beside the unthrottled figures of the same run
bench-pi: $(VENV)/.bench-installed
	QT_QPA_PLATFORM=offscreen $(PY) -m bench --pi

clean:
	rm -rf $(VENV) $(QT_OLDEST_VENV) build *.egg-info
	@if [ -f firmware/Makefile ]; then $(MAKE) -s -C firmware clean; fi

# Put deskarm in the desktop's application menu (double-click to start).
install-desktop: $(STAMP)
	mkdir -p $(HOME)/.local/share/applications $(HOME)/.local/share/icons/hicolor/scalable/apps
	sed "s|^Exec=deskarm|Exec=$(abspath $(VENV))/bin/deskarm|" resources/deskarm.desktop > $(HOME)/.local/share/applications/deskarm.desktop
	cp resources/deskarm.svg $(HOME)/.local/share/icons/hicolor/scalable/apps/deskarm.svg
	@echo "deskarm is now in your application menu"

# An emulated Raspberry Pi OS: a Debian Bookworm arm64 root file system (debootstrap + qemu-user),
# deskarm installed there with `make run` (headless: no display) and the core tests run under
# emulation. Needs root; the first run takes about an hour (see tests/arm64/check_arm64.sh).
check-arm64:
	bash tests/arm64/check_arm64.sh
