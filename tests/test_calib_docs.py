"""docs/calib.md's worked examples run as written and give the right answers.

Every command in the page's ``sh`` blocks is run (``out/calib`` moved to a
temporary folder), and each tool's answer is compared with the examples'
truth (``docs/examples/calib/truth.json``). The committed inputs must be what
``python -m calib.examples`` makes, so that the page and the generator never
drift apart.

The bounds on K are about twice the estimation error these fixed-seed inputs
give (0.05-0.9 % on the focal length, from 0.2-0.3 px of noise): a misread
input (columns swapped, a key ignored) misses them by far more.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from arstream.cli import main
from calib import examples

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "calib.md"
EXAMPLES = ROOT / "docs" / "examples" / "calib"
MODES = ("--points", "--spheres", "--fixed-image", "--data", "--coplanar")  # the options that choose a tool's input
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e-?\d+)?")


def doc_commands() -> list[list[str]]:
    """The commands of the page's ``sh`` blocks, split as a shell would."""
    blocks = re.findall(r"```sh\n(.*?)```", DOC.read_text(), flags=re.S)
    return [shlex.split(line) for block in blocks for line in block.splitlines() if line.strip()]


def focal_error(K, truth) -> float:
    K, truth = np.asarray(K), np.asarray(truth)
    return float(max(abs(K[0, 0] / truth[0, 0] - 1), abs(K[1, 1] / truth[1, 1] - 1)))


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Run the page's commands in order from the repository root; the output of each
    ``arstream calib`` command, keyed by the tool and its first option."""
    out = tmp_path_factory.mktemp("calib")
    res = {}
    with contextlib.chdir(ROOT):
        for cmd in doc_commands():
            cmd = [a.replace("out/calib", str(out)) for a in cmd]
            if cmd[:3] == [".venv/bin/python", "-m", "calib.examples"]:
                with contextlib.redirect_stdout(io.StringIO()):
                    assert examples.main(cmd[3:]) == 0
                continue
            assert cmd[0] == ".venv/bin/arstream" and cmd[1] == "calib", cmd
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                code = main(cmd[1:])
            assert code == 0, cmd
            mode = next((a for a in cmd if a in MODES), "plain")
            assert (cmd[2], mode) not in res, f"two examples of calib {cmd[2]} {mode}"
            res[(cmd[2], mode)] = json.loads(buf.getvalue())
    return res


@pytest.fixture(scope="module")
def truth():
    return json.loads((EXAMPLES / "truth.json").read_text())


def test_the_page_covers_every_tool_and_input(results):
    from arstream.commands import discover

    tools = {m.__name__.rsplit(".", 1)[-1].removeprefix("calib_").replace("_", "-") for m in discover("calib_")}
    assert tools == {"sphere", "one-d", "laser", "fmatrix"}
    assert set(results) == {
        ("sphere", "plain"),
        ("one-d", "--points"),
        ("one-d", "--spheres"),
        ("laser", "--data"),
        ("fmatrix", "plain"),
        ("fmatrix", "--coplanar"),
    }


def test_sphere(results, truth):
    r = results[("sphere", "plain")]
    assert focal_error(r["K"], truth["K"]) < 0.005 and not r["weak"]
    assert np.abs(np.subtract(r["K"], truth["K"])[:2, 2]).max() < 3.0  # principal point, px
    assert len(r["images"]) == 4


def test_one_d_rod(results, truth):
    r = results[("one-d", "--points")]
    assert r["method"] == "zhang" and focal_error(r["K"], truth["K"]) < 0.01
    assert np.abs(np.subtract(r["fixed_point"], truth["rod"]["fixed_point"])).max() < 1.5  # cm, of a point 150 cm away
    assert len(r["views"]) == 12


def test_one_d_spheres(results, truth):
    r = results[("one-d", "--spheres")]
    assert r["method"] == "two_spheres" and focal_error(r["K"], truth["K"]) < 0.02
    assert len(r["views"]) == 5


def test_laser(results, truth):
    r = results[("laser", "--data")]
    assert focal_error(r["K"], truth["K"]) < 0.01
    n, n_true = np.array(r["plane"]["normal"]), np.array(truth["plane"]["normal"])
    assert np.degrees(np.arccos(min(1.0, abs(n @ n_true)))) < 0.5
    assert abs(r["plane"]["d"] / truth["plane"]["d"] - 1) < 0.01


def test_fmatrix(results, truth):
    robust = results[("fmatrix", "plain")]
    assert robust["n_points"] == 100
    assert not any(robust["inliers"][i] for i in truth["wrong_matches"])  # every wrong match rejected
    assert sum(robust["inliers"]) >= 70  # of the 80 right ones (0.5 px of noise, a 1 px threshold)
    six = results[("fmatrix", "--coplanar")]
    F, G = np.array(six["F"]), np.array(truth["F"])  # both of unit norm
    assert min(np.abs(F - G).max(), np.abs(F + G).max()) < 1e-6  # exact matches, printed to 1e-6 px


def test_committed_inputs_are_the_generators(tmp_path):
    """The committed text inputs are what ``python -m calib.examples DIR --no-images``
    writes: the same text around the numbers, the numbers equal to within one unit of
    their last printed digit (a rounding that falls the other way on another machine)."""
    names = examples.write_examples(tmp_path, images=False)
    assert sorted(names) == sorted(p.name for p in EXAMPLES.iterdir())
    for name in names:
        made, kept = (tmp_path / name).read_text(), (EXAMPLES / name).read_text()
        assert NUMBER.sub("#", made) == NUMBER.sub("#", kept), name
        a = np.array([float(v) for v in NUMBER.findall(made)])
        b = np.array([float(v) for v in NUMBER.findall(kept)])
        assert np.allclose(a, b, rtol=1e-9, atol=0.011), name
