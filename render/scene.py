"""Scenes: a list of virtual objects and a few render settings, read from TOML or JSON.

A scene file (TOML shown; JSON has the same structure, ``"objects": [...]``)::

    [pitch]                 # optional; the pitch the objects stand on (default:
    length = 105.0          # the size the run solves at, given or estimated)
    width = 68.0            # metres along Y (default y_range of offside lines)

    [render]                # optional
    samples = 4             # MSAA samples (capped by the GL driver)
    matte_softness = 1.0    # pixels of blur applied to the grass matte's edges

    [[objects]]
    type = "logo"           # logo, offside_line, distance_ring, arrow, text, billboard, text3d
    image = "logo.png"      # relative paths are relative to the scene file
    center = [0.0, -18.0]
    size = [16.0, 5.0]

    [[objects]]
    type = "offside_line"
    x = 22.5

Keys of each object are the parameters of its class in :mod:`render.objects`.
Unknown keys, missing required keys and bad values are ``ValueError`` s that
name the file, the object (1-based) and the key.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from render.objects import OBJECT_TYPES, SceneObject

__all__ = ["Scene", "load_scene", "default_scene", "scene_from_dict", "DEMO_SCENE"]

#: The demo scene shipped with the package: a logo on the grass and an offside line.
DEMO_SCENE = Path(__file__).resolve().parent / "scenes" / "demo.toml"

_TOP_KEYS = {"pitch", "render", "objects"}


@dataclass
class Scene:
    """Objects in the pitch frame plus render settings.

    Attributes
    ----------
    objects : list of :class:`render.objects.SceneObject`, in drawing order
        (on the grass, later objects cover earlier ones)
    pitch_length, pitch_width : metres
    samples : int, MSAA samples requested
    matte_softness : float, pixels; the grass matte is blurred over about
        this radius where keyed objects are drawn (0 = use the matte as given)
    source : str or None, the file the scene came from
    """

    objects: list[SceneObject] = field(default_factory=list)
    pitch_length: float = 105.0
    pitch_width: float = 68.0
    samples: int = 4
    matte_softness: float = 1.0
    source: str | None = None

    def __post_init__(self) -> None:
        for i, obj in enumerate(self.objects, 1):
            if not isinstance(obj, SceneObject):
                raise ValueError(f"scene object {i} is not a render.objects.SceneObject: {type(obj).__name__}")
        if isinstance(self.samples, bool) or not isinstance(self.samples, int) or not 0 <= self.samples <= 16:
            raise ValueError(f"'samples' must be an integer 0..16, got {self.samples!r}")
        if not (isinstance(self.matte_softness, (int, float)) and 0.0 <= self.matte_softness <= 16.0):
            raise ValueError(f"'matte_softness' must be a number of pixels in [0, 16], got {self.matte_softness!r}")

    def parts(self):
        """All :class:`render.objects.Part` s in drawing order."""
        return [p for obj in self.objects for p in obj.parts()]


def _number(where: str, key: str, v, lo: float, hi: float) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
        raise ValueError(f"{where}: '{key}' must be a number in [{lo:g}, {hi:g}], got {v!r}")
    return float(v)


def scene_from_dict(data: dict, base_dir=".", source: str = "scene", pitch=None) -> Scene:
    """Build a :class:`Scene` from the parsed contents of a scene file.

    Parameters
    ----------
    data : dict with optional ``pitch``, ``render`` tables and an ``objects`` list
    base_dir : folder that relative image paths are resolved against
    source : name used in error messages (the file name)
    pitch : (length, width) metres of the pitch the run solves at, for a scene
        without a ``pitch`` table (default 105 x 68); a ``pitch`` table wins

    Raises
    ------
    ValueError
        Naming ``source``, the object number and the offending key.
    """
    if not isinstance(data, dict):
        raise ValueError(f"{source}: a scene must be a table/object at the top level")
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise ValueError(f"{source}: unknown top-level key '{unknown[0]}' (allowed: objects, pitch, render)")
    run_length, run_width = (105.0, 68.0) if pitch is None else (float(v) for v in pitch)
    pitch = data.get("pitch", {})
    rend = data.get("render", {})
    for name, table, keys in (("pitch", pitch, {"length", "width"}), ("render", rend, {"samples", "matte_softness"})):
        if not isinstance(table, dict):
            raise ValueError(f"{source}: '{name}' must be a table")
        bad = sorted(set(table) - keys)
        if bad:
            raise ValueError(f"{source}: [{name}]: unknown key '{bad[0]}' (allowed: {', '.join(sorted(keys))})")
    length = _number(f"{source}: [pitch]", "length", pitch.get("length", run_length), 90.0, 120.0)
    width = _number(f"{source}: [pitch]", "width", pitch.get("width", run_width), 45.0, 90.0)
    samples = rend.get("samples", 4)
    if isinstance(samples, bool) or not isinstance(samples, int) or not 0 <= samples <= 16:
        raise ValueError(f"{source}: [render]: 'samples' must be an integer 0..16, got {samples!r}")
    soft = _number(f"{source}: [render]", "matte_softness", rend.get("matte_softness", 1.0), 0.0, 16.0)

    items = data.get("objects", [])
    if not isinstance(items, list):
        raise ValueError(f"{source}: 'objects' must be a list of tables ([[objects]] in TOML)")
    objects = []
    for i, item in enumerate(items, 1):
        where = f"{source}: object {i}"
        if not isinstance(item, dict):
            raise ValueError(f"{where}: must be a table with a 'type'")
        typ = item.get("type")
        if typ is None:
            raise ValueError(f"{where}: missing 'type' (one of: {', '.join(sorted(OBJECT_TYPES))})")
        if typ not in OBJECT_TYPES:
            raise ValueError(f"{where}: unknown type {typ!r} (one of: {', '.join(sorted(OBJECT_TYPES))})")
        cls = OBJECT_TYPES[typ]
        where = f"{where} ({typ})"
        params = {f.name: f for f in dataclasses.fields(cls) if f.init}
        kwargs = {k: v for k, v in item.items() if k != "type"}
        unknown = sorted(set(kwargs) - set(params))
        if unknown:
            raise ValueError(f"{where}: unknown key '{unknown[0]}' (allowed: {', '.join(sorted(params))})")
        for name, f in params.items():
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING and name not in kwargs:
                raise ValueError(f"{where}: missing required key '{name}'")
        if "image" in kwargs and kwargs["image"] is not None:
            if not isinstance(kwargs["image"], str):
                raise ValueError(f"{where}: 'image' must be a file path, got {kwargs['image']!r}")
            kwargs["image"] = os.path.normpath(os.path.join(os.fspath(base_dir), kwargs["image"]))
        if typ == "offside_line" and "y_range" not in kwargs:
            kwargs["y_range"] = (-width / 2, width / 2)
        try:
            objects.append(cls(**kwargs))
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    return Scene(objects=objects, pitch_length=length, pitch_width=width, samples=samples, matte_softness=soft, source=source)


def load_scene(path, pitch=None) -> Scene:
    """Read a scene from a ``.toml`` or ``.json`` file (see the module docstring);
    ``pitch``: as for :func:`scene_from_dict`.

    Raises
    ------
    ValueError
        Missing file, unknown extension, a syntax error (with its line) or a
        bad object (see :func:`scene_from_dict`).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"scene file not found: {path}")
    ext = path.suffix.lower()
    try:
        if ext == ".toml":
            with open(path, "rb") as f:
                data = tomllib.load(f)
        elif ext == ".json":
            with open(path, encoding="utf-8") as f:
                data = json.load(f)
        else:
            raise ValueError(f"{path}: scene files must end in .toml or .json, got '{ext or path.name}'")
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: invalid TOML: {exc}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: invalid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    return scene_from_dict(data, base_dir=path.parent, source=str(path), pitch=pitch)


def default_scene(pitch=None) -> Scene:
    """The demo scene (``render/scenes/demo.toml``): a logo on the grass and an
    offside line across the pitch the run solves at (``pitch``: (length,
    width) metres, default 105 x 68)."""
    return load_scene(DEMO_SCENE, pitch=pitch)
