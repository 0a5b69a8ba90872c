"""Only the bridge URLs deskarm documents are accepted: spy://…?file=PATH would truncate PATH."""
import pytest

from core.devices import open_bridge, split_bridge_url
from core.devices.ports import validate_typed_path
from core.kinematics import load_profile

PROFILE = load_profile("desk_rrr")


@pytest.mark.parametrize("scheme", ["spy", "hwgrep", "alt", "cp2110"])
def test_pyserial_url_handlers_deskarm_does_not_document_are_refused_and_touch_no_file(tmp_path, scheme):
    victim = tmp_path / "notes.txt"
    victim.write_text("precious")
    url = f"{scheme}://loop://?file={victim}"
    for text in (url, f"v1:{url}", f"v2:{url}"):
        with pytest.raises(ValueError, match="unknown --bridge value"):
            split_bridge_url(text)
        with pytest.raises(ValueError):
            open_bridge(text, PROFILE)
    with pytest.raises(ValueError, match="is not accepted"):
        validate_typed_path(url)
    assert victim.read_text() == "precious"


@pytest.mark.parametrize("url", ["loop://", "socket://192.168.1.20:7777", "rfc2217://host:2217", "v2:loop://"])
def test_the_documented_urls_are_accepted(url):
    assert split_bridge_url(url)[1].endswith(url.split(":", 1)[1] if url.startswith("v2:") else url)
    assert validate_typed_path(url) == url
