"""An ONNX detector's onnxruntime threads sleep between runs (issue 28: a Pi 4 budget): spinning
after every run cost ~9 of the ~12 ms of CPU a run of the shipped desk model took, CPU a Pi's
cores need for the window and the rest of the loop. No timing assert: the session's settings."""
import pytest

from core.detect.registry import make_detector

ort = pytest.importorskip("onnxruntime")


def test_the_desk_model_s_onnxruntime_session_does_not_spin_between_runs():
    det = make_detector("desk")
    if det.backend != "onnxruntime":
        pytest.skip(f"the desk detector runs on {det.backend} here, not onnxruntime")
    session = det._session
    options = session.get_session_options()
    assert options.get_session_config_entry("session.intra_op.allow_spinning") == "0"
    assert options.get_session_config_entry("session.inter_op.allow_spinning") == "0"
