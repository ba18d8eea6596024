"""The user documentation inside the repository says what the code does
(issue 31): docs/formats.md names every key the writers write, one list of
system packages everywhere, and no pointer to design sections that are not
in the repository.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from arstream.batch import _record
from arstream.cli import build_parser
from arstream.estimate import CameraEstimate
from arstream.synth import TruthFrame
from geometry.camera import Camera
from render.context import DEBIAN_PACKAGES

ROOT = Path(__file__).resolve().parents[1]
FORMATS = (ROOT / "docs" / "formats.md").read_text()
README = (ROOT / "README.md").read_text()


def documented(key: str) -> bool:
    """``key`` appears in docs/formats.md as code (`key` in a table or the text)."""
    return re.search(rf"`{re.escape(key)}`", FORMATS) is not None


def _camera() -> Camera:
    R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    return Camera(K=np.array([[1000.0, 0.0, 640.0], [0.0, 1000.0, 360.0], [0.0, 0.0, 1.0]]), R=R, t=np.array([0.0, 10.0, 60.0]))


@pytest.mark.parametrize(
    "record",
    [
        CameraEstimate(0, 0.0, "ok", _camera(), 0.9).to_record(),
        CameraEstimate.lost(1, 0.04).to_record(),
        TruthFrame(0, 0.0, _camera(), True, True, 1.0).to_record(),
        TruthFrame(1, 0.04, None, False, False, 0.0).to_record(),
        _record("clip", "in/clip.mp4", "ok"),
        json.loads((ROOT / "samples" / "wide" / "header.json").read_text()),
    ],
    ids=["cameras ok", "cameras lost", "truth", "truth lost", "summary.jsonl", "header.json"],
)
def test_formats_names_every_key_written(record):
    assert [k for k in record if not documented(k)] == []


def test_formats_gives_the_statuses():
    assert all(documented(f'"{s}"') for s in ("ok", "tracked", "lost", "damaged", "failed", "interrupted", "cancelled"))


def test_one_list_of_system_packages():
    """README and docs/render.md give the apt-get line of the packages that
    render/context.py's error names (libEGL.so.1 and libGL.so.1 from libglvnd,
    Mesa's EGL driver and llvmpipe; GLES is not used)."""
    line = f"sudo apt-get update && sudo apt-get install -y {DEBIAN_PACKAGES}"
    render_md = (ROOT / "docs" / "render.md").read_text()
    assert README.count(line) == 1 and render_md.count(line) == 1
    assert DEBIAN_PACKAGES.split() == ["libegl1", "libegl-mesa0", "libgl1", "libgl1-mesa-dri"]
    for text in (README, render_md):
        assert "libgles2" not in text and len(re.findall(r"apt-get install", text)) == 1


def _help_texts(parser) -> list[str]:
    """The --help of ``parser`` and of all its sub-commands, depth first."""
    out = [parser.format_help()]
    for action in parser._actions:
        if hasattr(action, "_name_parser_map"):  # the sub-commands
            for child in dict.fromkeys(action.choices.values()):
                out += _help_texts(child)
    return out


def test_no_pointer_to_design_sections_outside_the_repository():
    """Users read README, the docs and --help; DESIGN.md is not in the repository."""
    texts = {"README.md": README}
    # every user page (docs/architecture.md is the developers' map, beside DESIGN.md)
    pages = [p for p in sorted((ROOT / "docs").glob("*.md")) if p.name != "architecture.md"] + [ROOT / "samples" / "README.md"]
    assert {"formats.md", "calib.md", "render.md", "evaluate.md", "real-footage.md"} <= {p.name for p in pages}
    for path in pages:
        texts[str(path.relative_to(ROOT))] = path.read_text()
    helps = _help_texts(build_parser())
    assert len(helps) >= 14  # arstream, its nine commands, the four calibration tools
    texts.update({f"--help {i}": h for i, h in enumerate(helps)})
    assert [name for name, text in texts.items() if "DESIGN.md" in text] == []
    assert "docs/formats.md" in README and "docs/calib.md" in README
