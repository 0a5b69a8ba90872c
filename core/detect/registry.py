"""Detectors by name: ``make_detector("hsv", min_area_px=50)``, ``parse_detector_list("aruco,hsv")``.

Plain names ("aruco", "hsv", "circles") build a detector from its settings dataclass
(``**options`` are its fields). Prefixed names ("onnx:PATH") hand the text after the colon to a
factory registered for the prefix. Factories may be import strings ("module:attr"), imported only
when used, so a detector whose dependencies are missing costs nothing until it is asked for.
"""
from __future__ import annotations

import importlib
from typing import Callable, Union

from core.detect.base import Detector

Factory = Union[Callable[..., Detector], str]  # a callable, or "package.module:attr" imported lazily

_NAMED: dict[str, Factory] = {
    "aruco": "core.detect.markers:make_aruco",
    "hsv": "core.detect.colour:make_hsv",
    "circles": "core.detect.circles:make_circles",
    "charuco": "core.detect.charuco:make_charuco",  # a ChArUco board (options: CharucoParams' fields)
    "diamond": "core.detect.charuco:make_diamond",  # ChArUco diamonds (options: DiamondParams' fields)
    # the shipped model (resources/models/desk_objects.onnx); options are OnnxYoloDetector's
    "desk": "core.detect.learned.shipped:make_desk_detector",
}
# prefix -> factory(argument, **options), e.g. "onnx" -> OnnxYoloDetector(path, **options)
_PREFIXED: dict[str, Factory] = {
    "onnx": "core.detect.onnx_yolo:OnnxYoloDetector",
}
_PREFIX_HELP = {"onnx": "onnx:PATH"}


def detector_names() -> tuple[str, ...]:
    """Every name ``make_detector`` accepts now, registrations included ("onnx:PATH" style for prefixes)."""
    return tuple(_NAMED) + tuple(_PREFIX_HELP.get(p, f"{p}:ARG") for p in _PREFIXED)


_names = detector_names

DETECTORS = detector_names()  # the built-in names: "aruco", "hsv", "circles", "charuco", "diamond", "desk", "onnx:PATH"


def register_detector(name: str, factory: Factory, prefix: bool = False) -> None:
    """Make ``name`` (or, with ``prefix``, every ``name:ARG``) build detectors with ``factory``.

    ``factory`` is a callable or an import string "module:attr". A plain factory is called with
    ``**options``; a prefix factory with ``(ARG, **options)``. Re-registering replaces.
    """
    if not name or ":" in name or "," in name or name != name.strip():
        raise ValueError(f"detector name {name!r} must be non-empty, without ':', ',' or surrounding spaces")
    (_PREFIXED if prefix else _NAMED)[name] = factory


def _resolve(factory: Factory, what: str) -> Callable[..., Detector]:
    if callable(factory):
        return factory
    module_name, _, attr = factory.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise ValueError(f"detector {what!r} is not available: {exc} (module {module_name})") from None
    try:
        return getattr(module, attr)
    except AttributeError:
        raise ValueError(f"detector {what!r} is not available: {module_name} has no {attr}") from None


def _check_name(name: str) -> str:
    text = str(name).strip()
    prefix, sep, arg = text.partition(":")
    if sep and prefix in _PREFIXED:
        if not arg.strip():
            raise ValueError(f"detector {text!r} needs something after the colon, e.g. {_PREFIX_HELP.get(prefix, prefix + ':ARG')}")
        return f"{prefix}:{arg.strip()}"
    if text in _NAMED:
        return text
    raise ValueError(f"unknown detector {text!r}; valid: {', '.join(_names())}")


def parse_detector_list(text: str) -> list[str]:
    """``"aruco, hsv"`` -> ``["aruco", "hsv"]``; ValueError for an empty list, an empty item,
    an unknown name or a name given twice (the message lists the valid names)."""
    items = [item.strip() for item in str(text).split(",")]
    if not any(items):
        raise ValueError(f"no detector given; valid: {', '.join(_names())}")
    if not all(items):
        raise ValueError(f"detector list {text!r} has an empty item (two commas, or one at an end)")
    names = [_check_name(item) for item in items]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ValueError(f"detector {', '.join(dupes)} is listed twice in {text!r}")
    return names


def make_detector(name: str, **options) -> Detector:
    """A detector by name: "aruco", "hsv", "circles", "charuco", "diamond" (options are its settings'
    fields), "desk" (the
    shipped model) or "onnx:PATH" (options go to the ONNX detector for both). ValueError for an unknown name or option,
    SettingsError (a ValueError) for a value out of range."""
    name = _check_name(name)
    prefix, sep, arg = name.partition(":")
    if sep:
        factory = _resolve(_PREFIXED[prefix], name)
        return factory(arg, **options)
    return _resolve(_NAMED[name], name)(**options)
