"""Offscreen rendering of a :class:`~render.scene.Scene` with a given camera.

::

    renderer = Renderer(1280, 720, load_scene("scene.toml"))
    overlay = renderer.render(camera, grass_matte=matte)   # premultiplied BGRA, H x W x 4
    Compositor(1280, 720).composite(frame_bgr, overlay)     # in place
    # or both at once: renderer.draw(frame_bgr, camera, grass_matte=matte)

Per frame
---------
1. *Footprint* (CPU, compiled loops: :mod:`render.kernels`): every triangle
   of the scene is projected with the camera (the same lens model as the
   vertex shader, see :mod:`render.camera_gl`); the 8 x 8 pixel tiles their
   bounding boxes touch are what the GPU resolves, and 32-pixel rectangles
   covering those tiles are what the compositor blends. The cost follows
   what is drawn, not the frame size.
2. *Draw* into a multisampled (MSAA) RGBA8 + depth framebuffer that is all
   zero between frames. Colours are premultiplied; "over" is
   ``blend_func = (ONE, ONE_MINUS_SRC_ALPHA)``. On-grass parts first, in scene
   order, without depth test; keyed parts multiply their colour by the grass
   matte, sampled at ``gl_FragCoord`` with a small blur (``matte_softness``
   pixels: the soft matte). Standing parts next, back to front, depth-tested
   and clipped by the pitch plane (``gl_ClipDistance = Z``).
3. *Resolve* the samples of the touched tiles with a shader into a
   single-sample RGBA8 framebuffer, swizzled to BGRA (OpenCV order); tiles
   drawn last frame but not now are zeroed in the same draw, so that
   framebuffer is exactly the overlay.
4. *Undraw*: the frame's triangles are drawn again with a shader that writes
   zero colour and far depth — exactly the samples the draw touched (same
   vertex shader, ``invariant gl_Position``) — which returns the
   multisampled target to zero. On a software rasteriser this is much
   cheaper than clearing whole tiles.
5. *One readback*: the rows spanned by the tiles, full width (so they land
   contiguously in a preallocated (H, W, 4) array). Rows come out top row
   first because the projection already flipped y (the one place this is
   decided: :func:`render.camera_gl.projection_from_K`).

Lens distortion: cameras with ``dist`` draw the finely tessellated meshes
(edges <= 0.5 m) distorted per vertex; pinhole cameras draw minimal meshes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import moderngl
import numpy as np

from geometry.camera import Camera
from render.camera_gl import _coeffs, projection_from_K, radial_limit, view_from_Rt
from render.compositor import Compositor
from render.context import create_context
from render.kernels import footprint_tiles, tile_runs
from render.scene import Scene, default_scene

__all__ = ["Renderer", "Overlay", "Footprint", "TILE", "BLOCK"]

#: Tile size (pixels) of the footprint grid: the GPU resolves these tiles.
TILE = 8
#: Compositing works on rectangles of BLOCK x BLOCK tiles (fewer, larger calls on the CPU).
BLOCK = 4

_GL_CLIP_DISTANCE0 = 0x3000

_OBJECT_VS = """
#version 330
uniform mat4 u_view;     // world (pitch) -> GL eye
uniform mat4 u_proj;     // GL eye -> clip; image rows top-down (see render.camera_gl)
uniform vec4 u_k;        // radial distortion k1..k4
uniform float u_r2max;   // r^2 clamp where the distortion stops being monotonic
uniform float u_clip_ground;
invariant gl_Position;   // the zeroing pass must cover exactly the samples the draw covered
in vec3 in_pos;
in vec2 in_uv;
out vec2 v_uv;
void main() {
    vec4 eye = u_view * vec4(in_pos, 1.0);
    float z = -eye.z;
    if (z > 0.0) {
        float r2 = min(dot(eye.xy, eye.xy) / (z * z), u_r2max);
        eye.xy *= 1.0 + r2 * (u_k.x + r2 * (u_k.y + r2 * (u_k.z + r2 * u_k.w)));
    }
    gl_Position = u_proj * eye;
    gl_ClipDistance[0] = u_clip_ground > 0.5 ? in_pos.z : 1.0;
    v_uv = in_uv;
}
"""

_OBJECT_FS = """
#version 330
// variants: TEXTURED (multiply by a premultiplied RGBA texture), KEYED (multiply by
// the grass matte), SOFT (blur the matte: two 2x2 gathers on the diagonal, a 3x3
// kernel [1 1 0; 1 2 1; 0 1 1] / 8 at matte_softness = 1 px; GATHER4: the same with
// four bilinear taps where textureGather is missing)
uniform vec4 u_color;        // premultiplied
#ifdef TEXTURED
uniform sampler2D u_tex;     // premultiplied RGBA
#endif
#ifdef KEYED
uniform sampler2D u_matte;   // grass matte, texture row = image row
uniform vec2 u_inv_size;
uniform float u_matte_scale;
#ifdef SOFT
uniform vec2 u_soft;         // half the blur radius, in texture units
#endif
#endif
in vec2 v_uv;
out vec4 f_color;
void main() {
    vec4 c = u_color;
#ifdef TEXTURED
    c *= texture(u_tex, v_uv);
#endif
#ifdef KEYED
    vec2 p = gl_FragCoord.xy * u_inv_size;
#if defined(SOFT) && !defined(GATHER4)
    vec4 q = textureGather(u_matte, p + u_soft) + textureGather(u_matte, p - u_soft);
    float m = 0.125 * (q.x + q.y + q.z + q.w);
#elif defined(SOFT)
    float m = 0.25 * (texture(u_matte, p + u_soft).r + texture(u_matte, p - u_soft).r
                    + texture(u_matte, p + vec2(u_soft.x, -u_soft.y)).r + texture(u_matte, p + vec2(-u_soft.x, u_soft.y)).r);
#else
    float m = texture(u_matte, p).r;
#endif
    c *= clamp(m * u_matte_scale, 0.0, 1.0);
#endif
    if (c.a < 0.5 / 255.0) discard;   // keep fully transparent texels out of the depth buffer
    f_color = c;
}
"""

_RESOLVE_VS = """
#version 330
uniform vec2 u_size;
in vec2 in_px;       // rectangle corners in pixels (image rows = framebuffer rows)
in float in_keep;    // 1: resolve the samples, 0: write zero (last frame's rectangles)
flat out float v_keep;
void main() {
    gl_Position = vec4(in_px / u_size * 2.0 - 1.0, 0.0, 1.0);
    v_keep = in_keep;
}
"""

_ZERO_FS = """
#version 330
// "un-draw": the same triangles as the last frame, writing zero colour and the far depth
out vec4 f_color;
void main() {
    f_color = vec4(0.0);
    gl_FragDepth = 1.0;
}
"""

_RESOLVE_FS_MS = """
#version 330
uniform sampler2DMS u_src;
flat in float v_keep;
out vec4 f_color;
void main() {
    if (v_keep < 0.5) { f_color = vec4(0.0); return; }
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 s = vec4(0.0);
    for (int i = 0; i < SAMPLES; ++i) s += texelFetch(u_src, q, i);
    f_color = (s * (1.0 / float(SAMPLES))).bgra;
}
"""

_RESOLVE_FS_SS = """
#version 330
uniform sampler2D u_src;
flat in float v_keep;
out vec4 f_color;
void main() {
    f_color = v_keep < 0.5 ? vec4(0.0) : texelFetch(u_src, ivec2(gl_FragCoord.xy), 0).bgra;
}
"""


@dataclass(frozen=True)
class Overlay:
    """A rendered frame of graphics.

    Attributes
    ----------
    bgra : (H, W, 4) uint8, premultiplied B, G, R, A in image order (row 0 at
        the top). A view of the renderer's buffer: valid until its next
        ``render`` (copy it to keep it).
    rects : tuple of (x0, y0, x1, y1) ints, disjoint pixel rectangles
        (half-open); the overlay is zero outside them.
    """

    bgra: np.ndarray
    rects: tuple

    @property
    def empty(self) -> bool:
        """True when nothing was drawn."""
        return not self.rects

    @property
    def alpha(self) -> np.ndarray:
        """(H, W) uint8 coverage (a view)."""
        return self.bgra[..., 3]

    @property
    def bbox(self) -> tuple[int, int, int, int] | None:
        """(x0, y0, x1, y1) union of the rectangles, or None when empty."""
        if not self.rects:
            return None
        r = np.array(self.rects)
        return int(r[:, 0].min()), int(r[:, 1].min()), int(r[:, 2].max()), int(r[:, 3].max())


class Footprint(NamedTuple):
    """Where a scene lands in the image for one camera.

    rects : list of (x0, y0, x1, y1) disjoint pixel rectangles aligned to
        ``TILE * BLOCK`` pixels, clipped to the frame, holding every pixel the
        scene can touch (what the compositor blends)
    tiles : (ny, nx) bool, the :data:`TILE`-pixel tiles the scene can touch
        (what the GPU resolves: tighter than ``rects``)
    visible : (P,) bool per part, at least one triangle in view
    near, far : float, depth range (metres) around the visible geometry
    """

    rects: list
    tiles: np.ndarray
    visible: np.ndarray | None
    near: float
    far: float


class _GPUPart:
    __slots__ = ("part", "vaos", "texture", "tri_start", "tri_stop", "centroid")


class Renderer:
    """Draw a scene's objects for a camera into a premultiplied BGRA overlay.

    Parameters
    ----------
    width, height : int, frame size in pixels
    scene : :class:`~render.scene.Scene`, default :func:`~render.scene.default_scene`
    ctx : moderngl.Context, optional; default a new one from
        :func:`render.context.create_context` (owned and released by the renderer)
    samples : int, optional, MSAA samples (default the scene's, capped by the driver)

    Use as a context manager or call :meth:`release`.
    """

    def __init__(self, width: int, height: int, scene: Scene | None = None, *, ctx: moderngl.Context | None = None, samples: int | None = None):
        if isinstance(width, bool) or isinstance(height, bool) or not isinstance(width, (int, np.integer)) or not isinstance(height, (int, np.integer)):
            raise ValueError(f"width and height must be integers, got {width!r} x {height!r}")
        if not (0 < width <= 16384 and 0 < height <= 16384):
            raise ValueError(f"frame size must be 1..16384 pixels each, got {width}x{height}")
        scene = default_scene() if scene is None else scene
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a render.scene.Scene, got {type(scene).__name__}")
        self.width, self.height = int(width), int(height)
        self.scene = scene
        self._own_ctx = ctx is None
        self.ctx = create_context() if ctx is None else ctx
        with self.ctx:
            self._setup(scene.samples if samples is None else int(samples))
        self._prev_tiles = np.zeros((self._nty, self._ntx), bool)
        self._prev_rows = (0, 0)
        self._drawn = None
        self.compositor = Compositor(self.width, self.height)

    # ------------------------------------------------------------------ setup
    def _setup(self, samples: int) -> None:
        ctx, W, H = self.ctx, self.width, self.height
        samples = max(0, min(samples, ctx.max_samples))
        self.samples = samples if samples > 1 else 0
        self._objects: list = []
        #: True on a software rasteriser (Mesa llvmpipe / softpipe / swrast)
        self.software = any(w in ctx.info.get("GL_RENDERER", "").lower() for w in ("llvmpipe", "softpipe", "swrast"))
        self._color_ms = ctx.texture((W, H), 4, samples=self.samples)
        self._depth_ms = ctx.depth_renderbuffer((W, H), samples=self.samples)
        self._fbo_draw = ctx.framebuffer([self._color_ms], self._depth_ms)
        self._fbo_draw.clear()  # from here on it is zero between frames (see _undraw)
        self._color_res = ctx.renderbuffer((W, H), 4)
        self._fbo_res = ctx.framebuffer([self._color_res])
        self._fbo_res.clear()
        self._objects += [self._color_ms, self._depth_ms, self._fbo_draw, self._color_res, self._fbo_res]

        self._programs: dict[tuple[bool, bool], moderngl.Program] = {}
        for textured in (False, True):
            for keyed in (False, True):
                defs = ("#define TEXTURED\n" if textured else "") + ("#define KEYED\n" if keyed else "")
                if keyed and self.scene.matte_softness > 0:
                    defs += "#extension GL_ARB_texture_gather : enable\n#define SOFT\n"
                    if "GL_ARB_texture_gather" not in ctx.extensions and ctx.version_code < 400:
                        defs += "#define GATHER4\n"
                prog = ctx.program(vertex_shader=_OBJECT_VS, fragment_shader=_OBJECT_FS.replace("#version 330\n", "#version 330\n" + defs, 1))
                if textured:
                    prog["u_tex"].value = 0
                if keyed:
                    prog["u_matte"].value = 1
                    prog["u_inv_size"].value = (1.0 / W, 1.0 / H)
                    if self.scene.matte_softness > 0:
                        prog["u_soft"].value = (0.5 * self.scene.matte_softness / W, 0.5 * self.scene.matte_softness / H)
                self._programs[(textured, keyed)] = prog
                self._objects.append(prog)
        fs = _RESOLVE_FS_MS.replace("SAMPLES", str(self.samples)) if self.samples else _RESOLVE_FS_SS
        self._resolve = ctx.program(vertex_shader=_RESOLVE_VS, fragment_shader=fs)
        self._objects.append(self._resolve)
        self._resolve["u_src"].value = 0
        self._resolve["u_size"].value = (float(W), float(H))

        self._zero = ctx.program(vertex_shader=_OBJECT_VS, fragment_shader=_ZERO_FS)
        self._objects.append(self._zero)
        # rectangles as two triangles each (x, y, keep); at most one per tile
        self._rect_cap = 2 * (-(-W // TILE)) * (-(-H // TILE))  # runs of tiles: stale + current
        self._rect_vbo = ctx.buffer(reserve=self._rect_cap * 6 * 3 * 4, dynamic=True)
        self._resolve_vao = ctx.vertex_array(self._resolve, [(self._rect_vbo, "2f 1f", "in_px", "in_keep")])
        self._objects += [self._rect_vbo, self._resolve_vao]
        self._matte_tex: dict[str, moderngl.Texture] = {}

        # scene geometry: GPU buffers per part, and one CPU copy of every triangle for the footprint
        textures: dict[int, moderngl.Texture] = {}
        self._parts: list[_GPUPart] = []
        positions, triangles, n_vert, n_tri = [], [], 0, 0
        for part in self.scene.parts():
            m = part.mesh
            g = _GPUPart()
            g.part = part
            textured = part.texture is not None
            g.vaos = {}
            for lod, mesh in (("fine", m), ("coarse", part.coarse if part.coarse is not None else m)):
                vbo = ctx.buffer(np.column_stack([mesh.positions, mesh.uv]).astype("f4").tobytes())
                ibo = ctx.buffer(mesh.triangles.astype("u4").tobytes())
                self._objects += [vbo, ibo]
                g.vaos[(lod, "zero")] = ctx.vertex_array(self._zero, [(vbo, "3f 8x", "in_pos")], index_buffer=ibo, index_element_size=4)
                self._objects.append(g.vaos[(lod, "zero")])
                for keyed in (False, True):
                    prog = self._programs[(textured, keyed)]
                    fmt, attrs = ("3f 2f", ("in_pos", "in_uv")) if textured else ("3f 8x", ("in_pos",))
                    vao = ctx.vertex_array(prog, [(vbo, fmt, *attrs)], index_buffer=ibo, index_element_size=4)
                    g.vaos[(lod, keyed)] = vao
                    self._objects.append(vao)
            g.texture = None
            if part.texture is not None:
                key = id(part.texture)
                if key not in textures:
                    tex = part.texture
                    t = ctx.texture((tex.shape[1], tex.shape[0]), 4, np.ascontiguousarray(tex).tobytes())
                    t.repeat_x = t.repeat_y = False
                    t.build_mipmaps()
                    t.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
                    if not self.software:  # anisotropic filtering costs llvmpipe ~5x per textured pixel
                        t.anisotropy = 8.0
                    textures[key] = t
                    self._objects.append(t)
                g.texture = textures[key]
            g.tri_start, g.tri_stop = n_tri, n_tri + len(m.triangles)
            g.centroid = part.centroid
            positions.append(m.positions.astype(np.float64))
            triangles.append(m.triangles.astype(np.int64) + n_vert)
            n_vert += len(m.positions)
            n_tri += len(m.triangles)
            self._parts.append(g)
        self._positions = np.concatenate(positions) if positions else np.zeros((0, 3))
        self._triangles = np.concatenate(triangles) if triangles else np.zeros((0, 3), np.int64)
        self._tri_part = np.repeat(np.arange(len(self._parts)), [g.tri_stop - g.tri_start for g in self._parts]) if self._parts else np.zeros(0, np.int64)

        self._buf = np.zeros((H, W, 4), np.uint8)
        self._ntx, self._nty = -(-W // TILE), -(-H // TILE)
        self._nbx, self._nby = -(-self._ntx // BLOCK), -(-self._nty // BLOCK)

    # ------------------------------------------------------------------ lifetime
    def release(self) -> None:
        """Free the GL objects (and the context when the renderer created it)."""
        if getattr(self, "ctx", None) is None:
            return
        with self.ctx:
            for o in reversed(self._objects + list(self._matte_tex.values())):
                o.release()
        self._objects, self._matte_tex = [], {}
        if self._own_ctx:
            self.ctx.release()
        self.ctx = None

    def __enter__(self) -> "Renderer":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    # ------------------------------------------------------------------ footprint
    def footprint(self, camera: Camera) -> Footprint:
        """Where the scene lands in the image for ``camera`` (CPU only, no GL).

        Every triangle of the finely tessellated meshes is projected with the
        same lens model as the vertex shader; triangles crossing the camera
        plane count as covering the whole frame.
        """
        W, H = self.width, self.height
        n_parts = len(self._parts)
        if len(self._triangles) == 0:
            return Footprint([], np.zeros((self._nty, self._ntx), bool), np.zeros(n_parts, bool), 0.1, 1.0)
        k = _coeffs(camera.dist)
        r2max = radial_limit(camera.dist) if np.any(k) else math.inf
        tiles, blocks, visible, near, far = footprint_tiles(
            self._positions, np.ascontiguousarray(camera.R, np.float64), np.ascontiguousarray(camera.t, np.float64), np.ascontiguousarray(camera.K, np.float64), k, float(r2max),
            self._triangles, self._tri_part, n_parts, W, H, TILE, BLOCK, self._ntx, self._nty, self._nbx, self._nby,
        )  # fmt: skip
        return Footprint(_rects_from_tiles(blocks, TILE * BLOCK, W, H), tiles, visible, near, far)

    # ------------------------------------------------------------------ frame
    def _upload_matte(self, matte: np.ndarray, y0: int, y1: int) -> float:
        """Upload rows y0..y1 of the matte (plus the blur's reach); returns the scale that maps it to 0..1."""
        h, w = matte.shape
        if (h, w) == (self.height, self.width):
            pad = int(math.ceil(self.scene.matte_softness)) + 2
            y0, y1 = max(y0 - pad, 0), min(y1 + pad, self.height)
        else:  # a small matte: all of it (the fragment shader samples normalised coordinates)
            y0, y1 = 0, h
        rows = matte[y0:y1]
        if matte.dtype == np.bool_:
            kind, data, scale = "f1", rows.view(np.uint8), 255.0
        elif matte.dtype == np.uint8:
            kind, data = "f1", rows
            scale = 255.0 if rows.size and int(rows.max()) <= 1 else 1.0
        else:
            kind, data, scale = "f4", rows.astype(np.float32, copy=False), 1.0
        tex = self._matte_tex.get((kind, h, w))
        if tex is None:
            tex = self.ctx.texture((w, h), 1, dtype=kind)
            tex.repeat_x = tex.repeat_y = False
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self._matte_tex[(kind, h, w)] = tex
        tex.write(np.ascontiguousarray(data), viewport=(0, y0, w, y1 - y0))
        tex.use(1)
        return scale

    def stretches_matte(self, shape) -> bool:
        """Whether a grass matte of ``shape`` (h, w), smaller than the frame, is taken
        as it is: stretched over the frame by the texture's bilinear filtering,
        which needs the frame's aspect ratio (within 2 %)."""
        h, w = shape[:2]
        return 0 < h < self.height and 0 < w < self.width and abs((self.width / w) / (self.height / h) - 1.0) <= 0.02

    def _check_matte(self, grass_matte) -> np.ndarray | None:
        if grass_matte is None:
            return None
        m = np.asarray(grass_matte)
        if m.ndim == 3 and m.shape[2] == 1:
            m = m[..., 0]
        if m.ndim == 2 and 0 < m.shape[0] < self.height and 0 < m.shape[1] < self.width:
            if not self.stretches_matte(m.shape):
                raise ValueError(f"a grass_matte smaller than the frame must have its aspect ratio: {m.shape} for ({self.height}, {self.width})")
        elif m.shape != (self.height, self.width):
            raise ValueError(f"grass_matte must be ({self.height}, {self.width}) like the frame, got {m.shape}")
        if m.dtype not in (np.bool_, np.uint8, np.float32, np.float64):
            raise ValueError(f"grass_matte must be bool, uint8 (255 = grass) or float (1 = grass), got {m.dtype}")
        return m

    def render(self, camera: Camera | None, grass_matte=None) -> Overlay:
        """Draw the scene seen by ``camera``.

        Parameters
        ----------
        camera : geometry.camera.Camera (OpenCV convention, pitch frame), or
            None for a frame without a camera (a "lost" frame: empty overlay)
        grass_matte : (H, W) array, a smaller one of the same aspect ratio, a
            callable, or None
            1 where the pixel is grass: bool; uint8 with 255 = grass (a 0/1
            uint8 mask is recognised by its maximum); or float in [0, 1].
            Keyed parts (on-grass objects by default) are multiplied by it,
            blurred by the scene's ``matte_softness``. A smaller matte (such
            as the detector's low-resolution grass mask) is stretched over the
            frame by bilinear texture filtering, at no CPU cost. A callable
            ``f(rects) -> matte`` is called with the overlay's rectangles
            (``(x0, y0, x1, y1)`` pixels) once they are known and need fill
            the matte only there (a fine key costs only where something is
            drawn); it is not called when nothing is in view. None: no keying.

        Returns
        -------
        Overlay, premultiplied BGRA (H, W, 4) in image order plus the
        rectangles that hold all of it.
        """
        if camera is not None and not isinstance(camera, Camera):
            raise ValueError(f"camera must be a geometry.camera.Camera or None, got {type(camera).__name__}")
        if self.ctx is None:
            raise ValueError("renderer was released")
        lazy_matte = callable(grass_matte)
        matte = None if lazy_matte else self._check_matte(grass_matte)
        if camera is None:
            fp = Footprint([], np.zeros_like(self._prev_tiles), None, 0.1, 1.0)
        else:
            _coeffs(camera.dist)  # validates the number of coefficients
            fp = self.footprint(camera)
        rects = fp.rects
        if lazy_matte and rects:
            matte = self._check_matte(grass_matte(list(rects)))
        runs = tile_runs(fp.tiles, TILE, self.width, self.height)  # what the GPU touches
        stale = tile_runs(self._prev_tiles & ~fp.tiles, TILE, self.width, self.height)  # drawn last frame, not now
        rows = (min(r[1] for r in rects), max(r[3] for r in rects)) if rects else (0, 0)
        with self.ctx:
            if len(runs) or len(stale):
                self._write_rects(stale, runs)
            if len(runs):
                self._draw(camera, fp, matte)
            if len(runs) or len(stale):
                self._fbo_res.use()
                self.ctx.enable_only(moderngl.NOTHING)
                self._color_ms.use(0)
                self._resolve_vao.render(moderngl.TRIANGLES, vertices=6 * (len(stale) + len(runs)))
            self._undraw()
            if rows[1] > rows[0]:  # the one readback: full rows, contiguous in the buffer
                self._fbo_res.read_into(self._buf[rows[0] : rows[1]], viewport=(0, rows[0], self.width, rows[1] - rows[0]), components=4)
        p0, p1 = self._prev_rows  # rows that held last frame's overlay but were not read back now
        for a, b in ((p0, min(p1, rows[0])), (max(p0, rows[1]), p1)) if rows[1] > rows[0] else ((p0, p1),):
            if b > a:
                self._buf[a:b] = 0
        self._prev_rows = rows
        self._prev_tiles = fp.tiles
        return Overlay(self._buf, tuple(rects))

    def _write_rects(self, stale: np.ndarray, runs: np.ndarray) -> None:
        """Fill the rectangle buffer: ``stale`` (the resolve writes zero) then ``runs`` (it resolves)."""
        r = np.concatenate([stale, runs]).astype(np.float32)
        keep = np.concatenate([np.zeros(len(stale), np.float32), np.ones(len(runs), np.float32)])
        x0, y0, x1, y1 = r.T
        data = np.stack([x0, y0, keep, x1, y0, keep, x1, y1, keep, x0, y0, keep, x1, y1, keep, x0, y1, keep], axis=1)
        self._rect_vbo.write(data.tobytes())

    def _draw(self, camera: Camera, fp: Footprint, matte) -> None:
        ctx, rects = self.ctx, fp.rects
        grass = [g for g, vis in zip(self._parts, fp.visible) if vis and g.part.on_grass]
        standing = [g for g, vis in zip(self._parts, fp.visible) if vis and not g.part.on_grass]
        self._fbo_draw.use()  # all zero: the last frame's draws were undone (see _undraw)
        view = view_from_Rt(camera.R, camera.t).T.astype("f4").tobytes()
        proj = projection_from_K(camera.K, self.width, self.height, fp.near, fp.far).T.astype("f4").tobytes()
        k = tuple(float(c) for c in _coeffs(camera.dist))
        r2max = float(min(radial_limit(camera.dist), 1e30))
        keyed = matte is not None and any(g.part.keyed for g in grass + standing)
        scale = self._upload_matte(matte, min(r[1] for r in rects), max(r[3] for r in rects)) if keyed else 1.0
        for prog in (*self._programs.values(), self._zero):
            prog["u_view"].write(view)
            prog["u_proj"].write(proj)
            prog["u_k"].value = k
            prog["u_r2max"].value = r2max
        for (_, k_prog), prog in self._programs.items():
            if k_prog:
                prog["u_matte_scale"].value = scale
        lod = "fine" if any(k) else "coarse"  # distorted cameras need the tessellated meshes
        ctx.enable_only(moderngl.BLEND)
        ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)  # premultiplied "over"
        for g in grass:
            self._draw_part(g, keyed, False, lod)
        if standing:
            c = camera.center
            standing.sort(key=lambda g: -float(np.sum((g.centroid - c) ** 2)))  # back to front
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
            ctx.enable_direct(_GL_CLIP_DISTANCE0)
            for g in standing:
                self._draw_part(g, keyed, True, lod)
            ctx.disable_direct(_GL_CLIP_DISTANCE0)
        ctx.enable_only(moderngl.NOTHING)
        self._drawn = (grass, standing, lod)

    def _undraw(self) -> None:
        """Return the multisampled target to all-zero colour and far depth by drawing the
        frame's triangles again (same vertex shader, same uniforms: the same samples,
        GL's invariance rules) with a shader that writes zero. Cheaper than clearing
        whole tiles on a software rasteriser, and exact."""
        if self._drawn is None:
            return
        grass, standing, lod = self._drawn
        self._drawn = None
        ctx, z = self.ctx, self._zero
        self._fbo_draw.use()
        ctx.enable_only(moderngl.NOTHING)
        z["u_clip_ground"].value = 0.0
        for g in grass:
            g.vaos[(lod, "zero")].render(moderngl.TRIANGLES)
        if standing:
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.depth_func = "1"  # always: reset depth where the draw may have written it
            ctx.enable_direct(_GL_CLIP_DISTANCE0)
            z["u_clip_ground"].value = 1.0
            for g in standing:
                g.vaos[(lod, "zero")].render(moderngl.TRIANGLES)
            ctx.disable_direct(_GL_CLIP_DISTANCE0)
        ctx.enable_only(moderngl.NOTHING)

    def _draw_part(self, g: _GPUPart, keyed: bool, clip_ground: bool, lod: str) -> None:
        vao = g.vaos[(lod, bool(keyed and g.part.keyed))]
        prog = vao.program
        prog["u_color"].value = g.part.rgba
        prog["u_clip_ground"].value = 1.0 if clip_ground else 0.0
        if g.texture is not None:
            g.texture.use(0)
        vao.render(moderngl.TRIANGLES)

    # ------------------------------------------------------------------ convenience
    def draw(self, frame: np.ndarray, camera: Camera | None, grass_matte=None) -> np.ndarray:
        """Render for ``camera`` and composite onto ``frame`` (BGR uint8, H x W x 3) in place; returns ``frame``."""
        return self.compositor.composite(frame, self.render(camera, grass_matte))


def _rects_from_tiles(tiles: np.ndarray, size: int, W: int, H: int) -> list[tuple[int, int, int, int]]:
    """Disjoint pixel rectangles (x0, y0, x1, y1) covering the marked cells (``size``
    pixels each): runs of cells per row, merged with the run just above when it
    spans the same columns."""
    if not tiles.any():
        return []
    d = np.diff(tiles.view(np.int8), axis=1, prepend=0, append=0)
    ys, xs = np.nonzero(d == 1)
    _, xe = np.nonzero(d == -1)  # same row-major order: the matching ends
    rects: list[list[int]] = []
    open_runs: dict[tuple[int, int], list[int]] = {}
    for ty, a, b in zip(ys.tolist(), xs.tolist(), xe.tolist()):
        r = open_runs.get((a, b))
        if r is not None and r[3] == ty:
            r[3] = ty + 1
        else:
            r = [a, ty, b, ty + 1]
            rects.append(r)
            open_runs[(a, b)] = r
    return [(a * size, y0 * size, min(b * size, W), min(y1 * size, H)) for a, y0, b, y1 in rects]
