"""Virtual objects described in pitch metres.

Frame (docs/formats.md): metres, origin at the centre spot, X along the
touchlines, Y along the halfway line away from the main camera, Z up; the
pitch is Z = 0. Angles are in degrees, counter-clockwise seen from above.

Every object is a small dataclass that validates its parameters and turns
itself into one or more :class:`Part` s: a triangle mesh in world
coordinates (tessellated with edges of at most :data:`MAX_EDGE` metres, so
the renderer's per-vertex lens distortion bends straight edges correctly),
a premultiplied RGBA colour, an optional premultiplied RGBA texture, and two
flags:

* ``on_grass`` — the part lies on the pitch (Z = 0). On-grass parts are drawn
  first, in scene order (later ones over earlier ones), without depth test.
* ``keyed`` — the part is multiplied by the grass matte, so players, the ball
  and anything that is not grass pass in front of it. Default: on-grass
  objects are keyed, standing objects are not (set ``keyed = true`` on a
  billboard to let players occlude it — it then also disappears over
  anything else that is not grass).

Standing parts (billboards, 3-D text) are depth-tested among themselves and
clipped by the pitch plane (nothing below Z = 0 shows); they are drawn over
the on-grass graphics, which is exact for a camera above the pitch.

Objects and their scene-file ``type``:

==================  =====================  ======================================
type                class                  what
==================  =====================  ======================================
``logo``            :class:`Logo`          textured image lying on the grass
``offside_line``    :class:`OffsideLine`   band across the pitch at a given X
``distance_ring``   :class:`DistanceRing`  ring around a point, with a label
``arrow``           :class:`Arrow`         arrow on the grass between two points
``text``            :class:`Text`          text lying on the grass
``billboard``       :class:`Billboard`     vertical textured quad standing on the pitch
``text3d``          :class:`Text3D`        standing, extruded 3-D text
==================  =====================  ======================================
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import ClassVar

import cv2
import numpy as np

from render.text import FONTS, premultiplied_rgba, text_mask

__all__ = [
    "MAX_EDGE",
    "Mesh",
    "Part",
    "SceneObject",
    "Logo",
    "OffsideLine",
    "DistanceRing",
    "Arrow",
    "Text",
    "Billboard",
    "Text3D",
    "OBJECT_TYPES",
    "parse_color",
    "load_image_rgba",
]

#: Longest triangle edge (metres) of the tessellated meshes.
MAX_EDGE = 0.5


# --------------------------------------------------------------------------- meshes
@dataclass
class Mesh:
    """A triangle mesh in the pitch frame.

    Attributes
    ----------
    positions : (N, 3) float32, metres
    uv : (N, 2) float32, texture coordinates; (0, 0) is the image's top-left corner
    triangles : (M, 3) uint32, indices into ``positions``
    """

    positions: np.ndarray
    uv: np.ndarray
    triangles: np.ndarray

    @staticmethod
    def concat(meshes: list["Mesh"]) -> "Mesh":
        pos, uv, tri, n = [], [], [], 0
        for m in meshes:
            pos.append(m.positions)
            uv.append(m.uv)
            tri.append(m.triangles + n)
            n += len(m.positions)
        return Mesh(np.concatenate(pos).astype(np.float32), np.concatenate(uv).astype(np.float32), np.concatenate(tri).astype(np.uint32))


@dataclass
class Part:
    """One draw call: a mesh, a premultiplied colour, an optional texture, two flags.

    ``rgba`` (4 floats, premultiplied) multiplies the texture when there is one
    (premultiplied RGBA uint8, (h, w, 4), row 0 = top of the image).
    ``mesh`` is tessellated with edges <= :data:`MAX_EDGE` (drawn for cameras
    with lens distortion, and used to find the footprint); ``coarse``, when
    given, is the same surface with as few triangles as possible (drawn for
    pinhole cameras, where straight edges stay straight: software rasterisers
    pay per triangle).
    """

    mesh: Mesh
    rgba: tuple[float, float, float, float]
    texture: np.ndarray | None
    on_grass: bool
    keyed: bool
    coarse: Mesh | None = None

    @property
    def centroid(self) -> np.ndarray:
        """(3,) mean vertex position, metres (used to sort standing parts back to front)."""
        return self.mesh.positions.astype(np.float64).mean(axis=0)


def _segments(length: float, max_edge: float = MAX_EDGE) -> int:
    return max(1, int(math.ceil(length / max_edge - 1e-9)))


def grid_mesh(p00, du, dv, max_edge: float = MAX_EDGE) -> Mesh:
    """Parallelogram ``p00 + u du + v dv`` (u, v in [0, 1]) tessellated with edges <= ``max_edge``.

    ``p00`` (3,) is where the texture's top-left corner goes; ``du`` (3,) runs
    along the texture's rows (left to right), ``dv`` (3,) down its columns.
    """
    p00, du, dv = (np.asarray(a, dtype=np.float64) for a in (p00, du, dv))
    nu, nv = _segments(np.linalg.norm(du), max_edge), _segments(np.linalg.norm(dv), max_edge)
    u, v = np.meshgrid(np.linspace(0.0, 1.0, nu + 1), np.linspace(0.0, 1.0, nv + 1))
    u, v = u.ravel(), v.ravel()
    pos = p00 + u[:, None] * du + v[:, None] * dv
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nv + 1, nu + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    tri = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return Mesh(pos.astype(np.float32), np.column_stack([u, v]).astype(np.float32), tri.astype(np.uint32))


def strip_mesh(left, right) -> Mesh:
    """Quads between two polylines ``left``, ``right`` ((n, 3) each, n >= 2); uv = (0|1, s)."""
    left, right = np.asarray(left, np.float64), np.asarray(right, np.float64)
    n = len(left)
    s = np.linspace(0.0, 1.0, n)
    pos = np.concatenate([left, right])
    uv = np.concatenate([np.column_stack([np.zeros(n), s]), np.column_stack([np.ones(n), s])])
    i = np.arange(n - 1)
    tri = np.concatenate([np.column_stack([i, i + n, i + n + 1]), np.column_stack([i, i + n + 1, i + 1])])
    return Mesh(pos.astype(np.float32), uv.astype(np.float32), tri.astype(np.uint32))


def _polyline(p0, p1, max_edge: float = MAX_EDGE) -> np.ndarray:
    p0, p1 = np.asarray(p0, np.float64), np.asarray(p1, np.float64)
    s = np.linspace(0.0, 1.0, _segments(np.linalg.norm(p1 - p0), max_edge) + 1)[:, None]
    return (1 - s) * p0 + s * p1


def _xyz(xy, z: float = 0.0) -> np.ndarray:
    return np.array([xy[0], xy[1], z], dtype=np.float64)


# --------------------------------------------------------------------------- validation helpers
def _number(name: str, v, *, positive: bool = False, nonneg: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(float(v)):
        raise ValueError(f"'{name}' must be a finite number, got {v!r}")
    v = float(v)
    if positive and not v > 0:
        raise ValueError(f"'{name}' must be positive, got {v:g}")
    if nonneg and v < 0:
        raise ValueError(f"'{name}' must not be negative, got {v:g}")
    return v


def _xy(name: str, v) -> tuple[float, float]:
    if isinstance(v, (str, bytes)) or not hasattr(v, "__len__") or len(v) != 2:
        raise ValueError(f"'{name}' must be 2 numbers [x, y] in metres, got {v!r}")
    return (_number(f"{name}[0]", v[0]), _number(f"{name}[1]", v[1]))


def _direction(name: str, v) -> tuple[float, float]:
    x, y = _xy(name, v)
    n = math.hypot(x, y)
    if n < 1e-9:
        raise ValueError(f"'{name}' must be a non-zero direction [x, y], got {list(v)!r}")
    return (x / n, y / n)


def _opacity(v) -> float:
    v = _number("opacity", v)
    if not 0.0 <= v <= 1.0:
        raise ValueError(f"'opacity' must be in [0, 1], got {v:g}")
    return v


def _bool(name: str, v) -> bool:
    if not isinstance(v, (bool, np.bool_)):
        raise ValueError(f"'{name}' must be true or false, got {v!r}")
    return bool(v)


def _text(name: str, v) -> str:
    if not isinstance(v, str) or not v.strip():
        raise ValueError(f"'{name}' must be a non-empty string, got {v!r}")
    return v


def parse_color(v, name: str = "color") -> tuple[float, float, float, float]:
    """Colour from ``"#rrggbb"``, ``"#rrggbbaa"`` or 3/4 numbers in [0, 1]: (r, g, b, a) floats, straight alpha."""
    if isinstance(v, str):
        s = v.strip()
        if s.startswith("#") and len(s) in (7, 9):
            try:
                vals = [int(s[i : i + 2], 16) / 255.0 for i in range(1, len(s), 2)]
            except ValueError:
                vals = None
            if vals is not None:
                return tuple(vals + [1.0] * (4 - len(vals)))  # type: ignore[return-value]
        raise ValueError(f"'{name}' must be \"#rrggbb\", \"#rrggbbaa\" or [r, g, b] in 0..1, got {v!r}")
    if not hasattr(v, "__len__") or len(v) not in (3, 4):
        raise ValueError(f"'{name}' must be \"#rrggbb\", \"#rrggbbaa\" or [r, g, b] in 0..1, got {v!r}")
    vals = [_number(f"{name}[{i}]", c) for i, c in enumerate(v)]
    if any(c < 0.0 or c > 1.0 for c in vals):
        raise ValueError(f"'{name}' components must be in [0, 1] (not 0..255), got {list(v)!r}")
    return tuple(vals + [1.0] * (4 - len(vals)))  # type: ignore[return-value]


def _premul(rgba, opacity: float) -> tuple[float, float, float, float]:
    a = float(rgba[3]) * opacity
    return (rgba[0] * a, rgba[1] * a, rgba[2] * a, a)


def load_image_rgba(image) -> np.ndarray:
    """An image file path, or an OpenCV-order array (H, W), (H, W, 3) BGR or (H, W, 4) BGRA,
    uint8 or uint16 -> premultiplied RGBA uint8 (H, W, 4), row 0 = top."""
    if isinstance(image, (str, os.PathLike)):
        path = os.fspath(image)
        if not os.path.isfile(path):
            raise ValueError(f"image file not found: {path}")
        img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
        if img is None:
            raise ValueError(f"cannot read image file: {path}")
    else:
        img = np.asarray(image)
    if img.dtype == np.uint16:
        img = (img >> 8).astype(np.uint8)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (1, 3, 4)):
        raise ValueError(f"image must be uint8 (H, W), (H, W, 3) BGR or (H, W, 4) BGRA, got {img.dtype} {img.shape}")
    if img.shape[0] < 1 or img.shape[1] < 1:
        raise ValueError("image is empty")
    if img.ndim == 2 or img.shape[2] == 1:
        img = cv2.cvtColor(img.reshape(img.shape[:2]), cv2.COLOR_GRAY2BGRA)
    elif img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2BGRA)
    rgba = cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA)
    a = rgba[..., 3:4].astype(np.uint16)
    rgba[..., :3] = ((rgba[..., :3].astype(np.uint16) * a + 127) // 255).astype(np.uint8)
    return rgba


# --------------------------------------------------------------------------- objects
@dataclass
class SceneObject:
    """Base class: subclasses set ``type`` (the scene-file name) and ``on_grass``."""

    type: ClassVar[str] = ""
    on_grass: ClassVar[bool] = True

    def parts(self) -> list[Part]:  # pragma: no cover - abstract
        raise NotImplementedError

    def outline(self) -> np.ndarray | None:
        """(K, 3) corners of the object's silhouette polygon in the pitch frame (metres),
        or None for shapes that are not polygons."""
        return None


def _frame_2d(rotation_deg: float) -> tuple[np.ndarray, np.ndarray]:
    th = math.radians(rotation_deg)
    e_u = np.array([math.cos(th), math.sin(th), 0.0])
    e_v = np.array([-math.sin(th), math.cos(th), 0.0])
    return e_u, e_v


@dataclass
class Logo(SceneObject):
    """A textured image lying on the grass.

    Parameters
    ----------
    image : path to an image file (PNG with alpha, JPEG, ...) or an array in
        OpenCV order ((H, W, 4) BGRA, (H, W, 3) BGR, (H, W) grey)
    center : (x, y) metres, centre of the logo on the pitch
    size : (width, height) metres, along the image's rows and columns
    rotation : degrees, counter-clockwise seen from above; at 0 the image's
        rows run along +X and its top points to +Y (away from the main
        camera), so it reads upright on the main camera
    opacity : 0..1
    keyed : bool, multiply by the grass matte (default True)
    """

    image: object
    center: tuple = (0.0, 0.0)
    size: tuple = (10.0, 4.0)
    rotation: float = 0.0
    opacity: float = 1.0
    keyed: bool = True
    type: ClassVar[str] = "logo"
    _texture: np.ndarray = field(init=False, repr=False, compare=False, default=None)

    def __post_init__(self) -> None:
        self.center = _xy("center", self.center)
        w, h = _xy("size", self.size)
        if not (w > 0 and h > 0):
            raise ValueError(f"'size' must be 2 positive numbers [width, height] in metres, got {list(self.size)!r}")
        self.size = (w, h)
        self.rotation = _number("rotation", self.rotation)
        self.opacity = _opacity(self.opacity)
        self.keyed = _bool("keyed", self.keyed)
        self._texture = load_image_rgba(self.image)

    def _corner_frame(self):
        e_u, e_v = _frame_2d(self.rotation)
        w, h = self.size
        p00 = _xyz(self.center) - 0.5 * w * e_u + 0.5 * h * e_v  # image top-left
        return p00, w * e_u, -h * e_v

    def parts(self) -> list[Part]:
        p00, du, dv = self._corner_frame()
        return [Part(grid_mesh(p00, du, dv), _premul((1.0, 1.0, 1.0, 1.0), self.opacity), self._texture, True, self.keyed, grid_mesh(p00, du, dv, math.inf))]

    def outline(self) -> np.ndarray:
        p00, du, dv = self._corner_frame()
        return np.array([p00, p00 + du, p00 + du + dv, p00 + dv])


@dataclass
class OffsideLine(SceneObject):
    """A band across the pitch (along Y) at a given X.

    Parameters
    ----------
    x : metres, the line's centre
    width : metres across the line
    y_range : (y_min, y_max) metres; default the pitch's touchlines (set by the scene)
    color, opacity, keyed : appearance (see module docstring)
    """

    x: float
    width: float = 0.15
    y_range: tuple | None = None
    color: object = "#ffd21f"
    opacity: float = 0.85
    keyed: bool = True
    type: ClassVar[str] = "offside_line"

    def __post_init__(self) -> None:
        self.x = _number("x", self.x)
        self.width = _number("width", self.width, positive=True)
        if self.y_range is None:
            self.y_range = (-34.0, 34.0)
        y0, y1 = _xy("y_range", self.y_range)
        if not y1 > y0:
            raise ValueError(f"'y_range' must be [y_min, y_max] with y_min < y_max, got {list(self.y_range)!r}")
        self.y_range = (y0, y1)
        self.color = parse_color(self.color)
        self.opacity = _opacity(self.opacity)
        self.keyed = _bool("keyed", self.keyed)

    def outline(self) -> np.ndarray:
        h = 0.5 * self.width
        (y0, y1), x = self.y_range, self.x
        return np.array([[x - h, y0, 0.0], [x + h, y0, 0.0], [x + h, y1, 0.0], [x - h, y1, 0.0]])

    def parts(self) -> list[Part]:
        c = self.outline()
        mesh = strip_mesh(_polyline(c[0], c[3]), _polyline(c[1], c[2]))
        coarse = strip_mesh(c[[0, 3]], c[[1, 2]])
        return [Part(mesh, _premul(self.color, self.opacity), None, True, self.keyed, coarse)]


def _flat_text_part(text, font, center, height, rotation, color, opacity, keyed) -> Part:
    mask = text_mask(text, font)
    aspect = mask.shape[1] / mask.shape[0]
    e_u, e_v = _frame_2d(rotation)
    w = height * aspect
    p00 = _xyz(center) - 0.5 * w * e_u + 0.5 * height * e_v
    tex = premultiplied_rgba(mask, (1.0, 1.0, 1.0))
    du, dv = w * e_u, -height * e_v
    return Part(grid_mesh(p00, du, dv), _premul(color, opacity), tex, True, keyed, grid_mesh(p00, du, dv, math.inf))


@dataclass
class DistanceRing(SceneObject):
    """A ring of a given radius around a point (e.g. the 9.15 m free-kick distance), with a label.

    Parameters
    ----------
    center : (x, y) metres
    radius : metres, to the ring's outer edge (as Law 1 measures distances)
    width : metres, the ring's thickness (inwards from ``radius``)
    label : str or None; default ``"<radius> m"``; ``""`` for none
    label_height : metres, height of the label's text box on the grass
    label_angle : degrees, where around the ring the label sits (-90 = the
        side nearest the main camera); the text reads upright on the main camera
    color, opacity, keyed : appearance; ``label_color`` defaults to ``color``
    """

    center: tuple = (0.0, 0.0)
    radius: float = 9.15
    width: float = 0.25
    label: str | None = None
    label_height: float = 1.2
    label_angle: float = -90.0
    color: object = "#ffffff"
    label_color: object = None
    opacity: float = 0.8
    font: str = "sans"
    keyed: bool = True
    type: ClassVar[str] = "distance_ring"

    def __post_init__(self) -> None:
        self.center = _xy("center", self.center)
        self.radius = _number("radius", self.radius, positive=True)
        self.width = _number("width", self.width, positive=True)
        if self.width >= self.radius:
            raise ValueError(f"'width' ({self.width:g}) must be less than 'radius' ({self.radius:g})")
        if self.label is None:
            self.label = f"{self.radius:g} m"
        elif not isinstance(self.label, str):
            raise ValueError(f"'label' must be a string, got {self.label!r}")
        self.label_height = _number("label_height", self.label_height, positive=True)
        self.label_angle = _number("label_angle", self.label_angle)
        self.color = parse_color(self.color)
        self.label_color = self.color if self.label_color is None else parse_color(self.label_color, "label_color")
        self.opacity = _opacity(self.opacity)
        if self.font not in FONTS:
            raise ValueError(f"'font' must be one of {', '.join(sorted(FONTS))}, got {self.font!r}")
        self.keyed = _bool("keyed", self.keyed)
        if self.label:
            text_mask(self.label, self.font)  # validate the text now

    def parts(self) -> list[Part]:
        r_out, r_in = self.radius, self.radius - self.width
        # chord error r (1 - cos(pi / n)) <= 2 mm: smooth at any broadcast zoom
        n = max(64, int(math.ceil(math.pi / math.acos(max(1.0 - 0.002 / r_out, -1.0)))))
        th = np.linspace(0.0, 2 * math.pi, n + 1)
        cs = np.column_stack([np.cos(th), np.sin(th), np.zeros_like(th)])
        c = _xyz(self.center)
        parts = [Part(strip_mesh(c + r_in * cs, c + r_out * cs), _premul(self.color, self.opacity), None, True, self.keyed)]
        if self.label:
            a = math.radians(self.label_angle)
            d = r_out + 0.4 + 0.6 * self.label_height
            pos = (c[0] + d * math.cos(a), c[1] + d * math.sin(a))
            parts.append(_flat_text_part(self.label, self.font, pos, self.label_height, 0.0, self.label_color, self.opacity, self.keyed))
        return parts


@dataclass
class Arrow(SceneObject):
    """An arrow lying on the grass from ``start`` to ``end`` (the tip).

    Parameters
    ----------
    start, end : (x, y) metres
    width : metres, shaft width
    head_length, head_width : metres (the head is shortened to fit short arrows)
    color, opacity, keyed : appearance
    """

    start: tuple = (0.0, 0.0)
    end: tuple = (10.0, 0.0)
    width: float = 0.5
    head_length: float = 2.0
    head_width: float = 1.6
    color: object = "#1fd0ff"
    opacity: float = 0.85
    keyed: bool = True
    type: ClassVar[str] = "arrow"

    def __post_init__(self) -> None:
        self.start = _xy("start", self.start)
        self.end = _xy("end", self.end)
        if math.dist(self.start, self.end) < 1e-6:
            raise ValueError("'start' and 'end' must differ")
        self.width = _number("width", self.width, positive=True)
        self.head_length = _number("head_length", self.head_length, positive=True)
        self.head_width = _number("head_width", self.head_width, positive=True)
        if self.head_width < self.width:
            raise ValueError(f"'head_width' ({self.head_width:g}) must be at least 'width' ({self.width:g})")
        self.color = parse_color(self.color)
        self.opacity = _opacity(self.opacity)
        self.keyed = _bool("keyed", self.keyed)

    def _points(self):
        p0, p1 = _xyz(self.start), _xyz(self.end)
        L = np.linalg.norm(p1 - p0)
        d = (p1 - p0) / L
        n = np.array([-d[1], d[0], 0.0])
        hl = min(self.head_length, 0.6 * L)
        base = p1 - hl * d
        return p0, p1, base, n

    def outline(self) -> np.ndarray:
        """(7, 3): shaft start (right, left), head base (left shaft, left wing), tip, (right wing, right shaft)."""
        p0, p1, base, n = self._points()
        w, hw = 0.5 * self.width, 0.5 * self.head_width
        return np.array([p0 - w * n, p0 + w * n, base + w * n, base + hw * n, p1, base - hw * n, base - w * n])

    def parts(self) -> list[Part]:
        p0, p1, base, n = self._points()
        w, hw = 0.5 * self.width, 0.5 * self.head_width
        shaft = strip_mesh(_polyline(p0 - w * n, base - w * n), _polyline(p0 + w * n, base + w * n))
        k = _segments(max(np.linalg.norm(p1 - base), self.head_width))
        s = np.linspace(0.0, 1.0, k + 1)[:, None]
        head = strip_mesh((1 - s) * (base - hw * n) + s * p1, (1 - s) * (base + hw * n) + s * p1)
        coarse = Mesh.concat([strip_mesh(np.array([p0 - w * n, base - w * n]), np.array([p0 + w * n, base + w * n])),
                              strip_mesh(np.array([base - hw * n, p1]), np.array([base + hw * n, p1]))])
        return [Part(Mesh.concat([shaft, head]), _premul(self.color, self.opacity), None, True, self.keyed, coarse)]


@dataclass
class Text(SceneObject):
    """Text lying on the grass (reads upright on the main camera at rotation 0).

    Parameters
    ----------
    text : one line of printable ASCII
    center : (x, y) metres
    height : metres, height of the text box (its width follows the text)
    rotation : degrees, counter-clockwise seen from above
    font : ``sans``, ``simplex``, ``serif`` or ``bold``
    color, opacity, keyed : appearance
    """

    text: str = "ARSTREAM"
    center: tuple = (0.0, 0.0)
    height: float = 2.0
    rotation: float = 0.0
    font: str = "sans"
    color: object = "#ffffff"
    opacity: float = 0.85
    keyed: bool = True
    type: ClassVar[str] = "text"

    def __post_init__(self) -> None:
        self.text = _text("text", self.text)
        self.center = _xy("center", self.center)
        self.height = _number("height", self.height, positive=True)
        self.rotation = _number("rotation", self.rotation)
        if self.font not in FONTS:
            raise ValueError(f"'font' must be one of {', '.join(sorted(FONTS))}, got {self.font!r}")
        self.color = parse_color(self.color)
        self.opacity = _opacity(self.opacity)
        self.keyed = _bool("keyed", self.keyed)
        text_mask(self.text, self.font)

    def parts(self) -> list[Part]:
        return [_flat_text_part(self.text, self.font, self.center, self.height, self.rotation, self.color, self.opacity, self.keyed)]


def _standing_frame(position, facing, width: float, top: float):
    """Top-left corner, row direction and column direction of a vertical quad whose
    front faces ``facing`` (2-D unit vector)."""
    right = np.array([-facing[1], facing[0], 0.0])  # seen from the front, the image's rows run this way
    p00 = _xyz(position, top) - 0.5 * width * right
    return p00, right


@dataclass
class Billboard(SceneObject):
    """A vertical textured quad standing on the pitch (a virtual advertising board).

    Parameters
    ----------
    position : (x, y) metres, middle of the bottom edge
    width, height : metres
    image : image file / array (see :class:`Logo`), or None for a plain ``color`` board
    color : the board's colour when there is no image, else a tint (default white)
    facing : (x, y) direction the front faces (default (0, -1): toward the main camera)
    elevation : metres, height of the bottom edge above the grass
    opacity, keyed : appearance (not keyed by default)
    """

    position: tuple = (0.0, 0.0)
    width: float = 6.0
    height: float = 1.0
    image: object = None
    color: object = "#ffffff"
    facing: tuple = (0.0, -1.0)
    elevation: float = 0.0
    opacity: float = 1.0
    keyed: bool = False
    type: ClassVar[str] = "billboard"
    on_grass: ClassVar[bool] = False
    _texture: np.ndarray | None = field(init=False, repr=False, compare=False, default=None)

    def __post_init__(self) -> None:
        self.position = _xy("position", self.position)
        self.width = _number("width", self.width, positive=True)
        self.height = _number("height", self.height, positive=True)
        self.color = parse_color(self.color)
        self.facing = _direction("facing", self.facing)
        self.elevation = _number("elevation", self.elevation)
        self.opacity = _opacity(self.opacity)
        self.keyed = _bool("keyed", self.keyed)
        self._texture = None if self.image is None else load_image_rgba(self.image)

    def outline(self) -> np.ndarray:
        p00, right = _standing_frame(self.position, self.facing, self.width, self.elevation + self.height)
        down = np.array([0.0, 0.0, -self.height])
        return np.array([p00, p00 + self.width * right, p00 + self.width * right + down, p00 + down])

    def parts(self) -> list[Part]:
        p00, right = _standing_frame(self.position, self.facing, self.width, self.elevation + self.height)
        du, dv = self.width * right, np.array([0.0, 0.0, -self.height])
        return [Part(grid_mesh(p00, du, dv), _premul(self.color, self.opacity), self._texture, False, self.keyed, grid_mesh(p00, du, dv, math.inf))]


@dataclass
class Text3D(SceneObject):
    """Standing 3-D text: glyphs extruded ``depth`` metres behind their front face.

    The extrusion is drawn as closely stacked glyph layers (every 2 cm, at
    most 32): the front and back layers in ``color``, the ones between in
    ``side_color`` (three draw calls in all). Seen from a broadcast camera
    the layers merge into solid sides.

    Parameters
    ----------
    text : one line of printable ASCII
    position : (x, y) metres, middle of the text's baseline box on the pitch
    height : metres, height of the text box
    facing : (x, y) direction the front faces (default toward the main camera)
    depth : metres of extrusion (0 for flat standing text)
    elevation : metres above the grass
    font, color, side_color (default: color at 55 % brightness), opacity, keyed
    """

    text: str = "GOAL"
    position: tuple = (0.0, 0.0)
    height: float = 2.0
    facing: tuple = (0.0, -1.0)
    depth: float = 0.3
    elevation: float = 0.0
    font: str = "sans"
    color: object = "#ffffff"
    side_color: object = None
    opacity: float = 1.0
    keyed: bool = False
    type: ClassVar[str] = "text3d"
    on_grass: ClassVar[bool] = False

    def __post_init__(self) -> None:
        self.text = _text("text", self.text)
        self.position = _xy("position", self.position)
        self.height = _number("height", self.height, positive=True)
        self.facing = _direction("facing", self.facing)
        self.depth = _number("depth", self.depth, nonneg=True)
        self.elevation = _number("elevation", self.elevation)
        if self.font not in FONTS:
            raise ValueError(f"'font' must be one of {', '.join(sorted(FONTS))}, got {self.font!r}")
        self.color = parse_color(self.color)
        if self.side_color is None:
            self.side_color = (0.55 * self.color[0], 0.55 * self.color[1], 0.55 * self.color[2], self.color[3])
        else:
            self.side_color = parse_color(self.side_color, "side_color")
        self.opacity = _opacity(self.opacity)
        self.keyed = _bool("keyed", self.keyed)
        text_mask(self.text, self.font)

    def parts(self) -> list[Part]:
        mask = text_mask(self.text, self.font)
        width = self.height * mask.shape[1] / mask.shape[0]
        tex = premultiplied_rgba(mask, (1.0, 1.0, 1.0))
        p00, right = _standing_frame(self.position, self.facing, width, self.elevation + self.height)
        back = -np.array([self.facing[0], self.facing[1], 0.0])
        n = 1 if self.depth <= 0 else min(32, max(2, int(math.ceil(self.depth / 0.02)) + 1))
        du, dv = width * right, np.array([0.0, 0.0, -self.height])

        def layers(idx):  # one mesh of the layers idx, listed back (largest offset) to front
            idx = sorted(idx, reverse=True)
            offs = [(self.depth * i / (n - 1) if n > 1 else 0.0) * back for i in idx]
            return (Mesh.concat([grid_mesh(p00 + o, du, dv) for o in offs]),
                    Mesh.concat([grid_mesh(p00 + o, du, dv, math.inf) for o in offs]))

        # three draws: back face, the sides (the layers between), front face; the renderer
        # sorts standing parts back to front by centroid, so the order follows the camera
        groups = [([0], self.color)] if n == 1 else [([n - 1], self.color), (list(range(1, n - 1)), self.side_color), ([0], self.color)]
        parts = []
        for idx, col in groups:
            if idx:
                mesh, coarse = layers(idx)
                parts.append(Part(mesh, _premul(col, self.opacity), tex, False, self.keyed, coarse))
        return parts


#: Scene-file ``type`` -> class.
OBJECT_TYPES: dict[str, type[SceneObject]] = {
    cls.type: cls for cls in (Logo, OffsideLine, DistanceRing, Arrow, Text, Billboard, Text3D)
}
