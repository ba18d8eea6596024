"""Tests of ``render``: a real EGL context (llvmpipe on CPU machines), pixels
compared against the camera's own projection, occlusion by the grass matte,
compositing arithmetic, and the error paths.

Geometric exactness is measured, not eyeballed: the rendered alpha is sampled
across each edge of an object's silhouette near every corner, the 0.5
crossings give sub-pixel edge points, lines fitted to them intersect at the
rendered corner, and that corner is compared with ``Camera.project`` of the
object's corner in pitch metres (target: within 0.5 px).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import cv2
import numpy as np
import pytest

from geometry.camera import Camera
from render import (
    Arrow,
    Billboard,
    Compositor,
    DistanceRing,
    GLContextError,
    Logo,
    OffsideLine,
    Overlay,
    Renderer,
    Scene,
    Text,
    Text3D,
    create_context,
    default_scene,
    load_scene,
)
from render.camera_gl import clip_from_world, pixels_from_clip, projection_from_K, radial_limit, view_from_Rt
from render.compositor import composite_over
from render.synthetic import main_camera, pitch_frame

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

W, H = 1280, 720
WHITE = np.full((8, 8, 4), 255, np.uint8)  # an opaque white "logo": alpha is pure coverage


@pytest.fixture(scope="module")
def ctx():
    c = create_context()
    yield c
    c.release()


def _render_alpha(ctx, objects, camera, size=(W, H), grass_matte=None) -> np.ndarray:
    with Renderer(size[0], size[1], Scene(list(objects)), ctx=ctx) as r:
        return r.render(camera, grass_matte).alpha.astype(np.float64) / 255.0


# --------------------------------------------------------------------------- sub-pixel measurement
def _bilinear(img, pts):
    h, w = img.shape
    x, y = pts[:, 0], pts[:, 1]
    x0 = np.clip(np.floor(x).astype(int), 0, w - 2)
    y0 = np.clip(np.floor(y).astype(int), 0, h - 2)
    fx, fy = x - x0, y - y0
    return (img[y0, x0] * (1 - fx) * (1 - fy) + img[y0, x0 + 1] * fx * (1 - fy)
            + img[y0 + 1, x0] * (1 - fx) * fy + img[y0 + 1, x0 + 1] * fx * fy)


def _crossing(alpha, p, n_out, reach=3.0, step=0.02):
    """Point where alpha falls through 0.5 along the outward direction ``n_out``, nearest ``p``."""
    t = np.arange(-reach, reach + step / 2, step)
    vals = _bilinear(alpha, p[None, :] + t[:, None] * n_out[None, :])
    inside = vals >= 0.5
    idx = np.flatnonzero(inside[:-1] & ~inside[1:])
    if len(idx) == 0:
        return None
    i = idx[np.argmin(np.abs(t[idx]))]
    a, b = vals[i], vals[i + 1]
    return p + (t[i] + step * (a - 0.5) / (a - b)) * n_out


def _edge_line(cam, alpha, A, B, margin):
    """Fit a line to measured edge points of world edge A -> B, from ``margin`` px after A
    to 60 px after A or ``margin`` px before B: near A, where the edge is nearly straight
    even under lens distortion."""
    s = np.linspace(0.0, 1.0, 2001)[:, None]
    px = cam.project((1 - s) * A + s * B)
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(px, axis=0), axis=1))]
    d = np.linspace(margin, min(margin + 60.0, arc[-1] - 6.0), 30)
    pts = np.column_stack([np.interp(d, arc, px[:, 0]), np.interp(d, arc, px[:, 1])])
    ahead = np.column_stack([np.interp(d + 0.5, arc, px[:, 0]), np.interp(d + 0.5, arc, px[:, 1])])
    tang = (ahead - pts) / np.linalg.norm(ahead - pts, axis=1)[:, None]
    meas = []
    for p, tv in zip(pts, tang):
        nv = np.array([tv[1], -tv[0]])
        if _bilinear(alpha, (p + 2 * nv)[None])[0] > _bilinear(alpha, (p - 2 * nv)[None])[0]:
            nv = -nv  # outward = toward lower alpha
        q = _crossing(alpha, p, nv)
        if q is not None:
            meas.append(q)
    assert len(meas) >= 10, f"edge not found near {cam.project(A[None])[0]}"
    P = np.array(meas)
    c = P.mean(axis=0)
    return c, np.linalg.svd(P - c)[2][0]


def _rendered_corner(cam, alpha, prev, corner, nxt) -> np.ndarray:
    img = cam.project(np.array([prev, corner, nxt]))
    u, v = img[0] - img[1], img[2] - img[1]
    angle = math.acos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1))
    margin = 3.0 + 4.0 / max(math.sin(angle), 0.2)  # keep the other edge out of the profiles
    c1, d1 = _edge_line(cam, alpha, corner, prev, margin)
    c2, d2 = _edge_line(cam, alpha, corner, nxt, margin)
    t = np.linalg.solve(np.column_stack([d1, -d2]), c2 - c1)
    return c1 + t[0] * d1


def _corner_errors(cam, alpha, outline, size=(W, H)):
    """Errors (px) between rendered and projected corners, for corners well inside the frame."""
    img = cam.project(outline)
    errs = []
    for k in range(len(outline)):
        x, y = img[k]
        if not (15 < x < size[0] - 15 and 15 < y < size[1] - 15):
            continue
        got = _rendered_corner(cam, alpha, outline[k - 1], outline[k], outline[(k + 1) % len(outline)])
        errs.append(float(np.linalg.norm(got - img[k])))
    return errs


# --------------------------------------------------------------------------- cameras
CAMERAS = {
    "centred": main_camera(W, H, pan_deg=-5, tilt_deg=22, hfov_deg=40),
    "offset_pp": main_camera(W, H, pan_deg=-5, tilt_deg=22, hfov_deg=40, principal_point=(700.3, 321.7)),
    "far_offset_pp_roll": main_camera(W, H, pan_deg=-9, tilt_deg=19, roll_deg=4, hfov_deg=44, principal_point=(480.0, 440.0)),
    "distorted": main_camera(W, H, pan_deg=-5, tilt_deg=22, hfov_deg=40, principal_point=(650.0, 352.0), dist=(-0.12, 0.02)),
    "telephoto_offset_pp": main_camera(W, H, pan_deg=-7, tilt_deg=25, hfov_deg=22, principal_point=(610.0, 380.0)),
}


def _polygon_objects():
    return [
        Logo(WHITE, center=(-6.0, -14.0), size=(10.0, 4.0), rotation=12.0),
        OffsideLine(x=1.0, width=0.8, y_range=(-20.0, -10.0), opacity=1.0),
        Arrow(start=(-15.0, -22.0), end=(-1.0, -18.0), width=2.5, head_length=5.0, head_width=7.5, opacity=1.0),
        Billboard(position=(-8.0, -25.0), width=6.0, height=2.5, facing=(0.2, -1.0)),
    ]


# --------------------------------------------------------------------------- camera -> GL
@pytest.mark.parametrize("name", sorted(CAMERAS))
def test_gl_matrices_reproduce_camera_projection(name):
    cam = CAMERAS[name]
    X = np.array([[0.0, 0.0, 0.0], [-30.0, -20.0, 0.0], [20.0, 10.0, 2.5], [5.0, -25.0, 1.0]])
    px = pixels_from_clip(clip_from_world(cam, X, W, H, 1.0, 500.0), W, H)
    np.testing.assert_allclose(px, cam.project(X), atol=1e-8)


def test_projection_maps_pixel_centres_and_rows_top_down():
    K = np.array([[1000.0, 0.0, 600.25], [0.0, 1000.0, 330.75], [0.0, 0.0, 1.0]])
    P = projection_from_K(K, W, H, 1.0, 100.0)
    V = view_from_Rt(np.eye(3), np.zeros(3))
    # a point on the optical axis lands on the principal point; row 0 maps to NDC y = -1 + 1/H
    eye = V @ np.array([0.0, 0.0, 10.0, 1.0])
    ndc = (P @ eye)[:3] / (P @ eye)[3]
    assert ndc[0] == pytest.approx(2 * (600.25 + 0.5) / W - 1)
    assert ndc[1] == pytest.approx(2 * (330.75 + 0.5) / H - 1)
    eye = V @ np.array([-600.25 / 1000 * 10, -330.75 / 1000 * 10, 10.0, 1.0])  # pixel (0, 0)
    ndc = (P @ eye)[:2] / (P @ eye)[3]
    np.testing.assert_allclose(ndc, [-1 + 1 / W, -1 + 1 / H])
    for z, want in ((1.0, -1.0), (100.0, 1.0)):
        clip = P @ (V @ np.array([0.0, 0.0, z, 1.0]))
        assert clip[2] / clip[3] == pytest.approx(want)


def test_radial_limit_keeps_distortion_monotonic():
    assert radial_limit(()) == math.inf
    assert radial_limit((0.1,)) == math.inf
    assert radial_limit((-0.12,)) == pytest.approx(1 / 0.36)
    with pytest.raises(ValueError, match="at most 4 radial coefficients"):
        radial_limit((0.1, 0.0, 0.0, 0.0, 0.01))


# --------------------------------------------------------------------------- geometric exactness
@pytest.mark.parametrize("name", sorted(CAMERAS))
def test_rendered_corners_match_projection(ctx, name):
    cam = CAMERAS[name]
    measured = 0
    for obj in _polygon_objects():
        alpha = _render_alpha(ctx, [obj], cam)
        errs = _corner_errors(cam, alpha, obj.outline())
        if len(errs) < 3:
            continue  # this object is not (well) in this camera's view
        measured += 1
        assert max(errs) < 0.5, f"{type(obj).__name__}: corner errors {np.round(errs, 3)} px"
    assert measured >= 2, "the test scene must be in view"


@pytest.mark.parametrize("name", ["centred", "far_offset_pp_roll", "distorted"])
def test_distance_ring_edge_on_projected_circle(ctx, name):
    cam = CAMERAS[name]
    ring = DistanceRing(center=(-4.0, -16.0), radius=5.0, width=1.0, label="", opacity=1.0)
    alpha = _render_alpha(ctx, [ring], cam)
    th = np.linspace(0.0, 2 * np.pi, 73)[:-1]
    for r, sign in ((5.0, 1.0), (4.0, -1.0)):  # outer edge: alpha drops outwards; inner: inwards
        pts = cam.project(np.column_stack([-4.0 + r * np.cos(th), -16.0 + r * np.sin(th), np.zeros_like(th)]))
        ahead = cam.project(np.column_stack([-4.0 + r * np.cos(th + 1e-4), -16.0 + r * np.sin(th + 1e-4), np.zeros_like(th)]))
        out = cam.project(np.column_stack([-4.0 + (r + sign * 1e-3) * np.cos(th), -16.0 + (r + sign * 1e-3) * np.sin(th), np.zeros_like(th)]))
        errs = []
        for p, a, o in zip(pts, ahead, out):
            tang = (a - p) / np.linalg.norm(a - p)
            nv = np.array([tang[1], -tang[0]])
            nv = nv if nv @ (o - p) > 0 else -nv
            q = _crossing(alpha, p, nv, reach=2.0)
            assert q is not None
            errs.append(float((q - p) @ nv))
        assert np.max(np.abs(errs)) < 0.5, f"radius {r}: edge offsets up to {np.max(np.abs(errs)):.3f} px"


def test_standing_billboard_is_clipped_by_the_pitch(ctx):
    cam = CAMERAS["centred"]
    sunk = Billboard(position=(-8.0, -25.0), width=6.0, height=2.5, elevation=-1.0)  # 1 m below the grass
    alpha = _render_alpha(ctx, [sunk], cam)
    ground = Billboard(position=(-8.0, -25.0), width=6.0, height=1.5)  # what should remain
    diff = np.abs(alpha - _render_alpha(ctx, [ground], cam))
    assert diff.max() <= 0.25 + 1e-9 and np.count_nonzero(diff) <= 5  # at most a sample on a few edge pixels


def test_standing_objects_are_depth_sorted(ctx):
    cam = CAMERAS["centred"]
    near = Billboard(position=(-6.0, -26.0), width=4.0, height=2.0, color="#ff0000")
    far = Billboard(position=(-5.0, -22.0), width=6.0, height=4.0, color="#0000ff")
    outs = []
    for objs in ([near, far], [far, near]):
        with Renderer(W, H, Scene(objs), ctx=ctx) as r:
            outs.append(r.render(cam).bgra.copy())
    np.testing.assert_array_equal(outs[0], outs[1])
    c = np.round(cam.project(np.array([[-6.0, -26.0, 1.0]]))[0]).astype(int)
    b, g, rr, a = outs[0][c[1], c[0]]
    assert (rr, b, a) == (255, 0, 255)  # the near (red) board covers the far (blue) one


def test_msaa_antialiases_edges(ctx):
    alpha = _render_alpha(ctx, [Logo(WHITE, center=(-6.0, -14.0), size=(10.0, 4.0), rotation=12.0)], CAMERAS["centred"])
    partial = np.count_nonzero((alpha > 0.05) & (alpha < 0.95))
    assert partial > 200  # soft edges all round the logo
    assert set(np.unique(np.round(alpha[(alpha > 0) & (alpha < 1)] * 4) / 4)) >= {0.25, 0.5, 0.75}


def test_textured_logo_orientation(ctx):
    """The image's top-left corner goes to the logo corner at -width/2 e_u + height/2 e_v."""
    img = np.zeros((40, 100, 4), np.uint8)
    img[..., 3] = 255
    img[:20, :50] = (0, 0, 255, 255)  # top-left quadrant red (BGRA)
    logo = Logo(img, center=(-6.0, -14.0), size=(10.0, 4.0))
    cam = CAMERAS["centred"]
    with Renderer(W, H, Scene([logo]), ctx=ctx) as r:
        ov = r.render(cam).bgra.copy()
    tl = np.round(cam.project(np.array([[-6.0 - 2.5, -14.0 + 1.0, 0.0]]))[0]).astype(int)
    br = np.round(cam.project(np.array([[-6.0 + 2.5, -14.0 - 1.0, 0.0]]))[0]).astype(int)
    assert tuple(ov[tl[1], tl[0]]) == (0, 0, 255, 255)  # red, as BGRA
    assert tuple(ov[br[1], br[0]]) == (0, 0, 0, 255)


def test_text_objects_draw_inside_their_boxes(ctx):
    cam = CAMERAS["centred"]
    for obj in (Text(text="ARSTREAM", center=(-6.0, -14.0), height=2.0, opacity=1.0),
                Text3D(text="GOAL", position=(-6.0, -20.0), height=2.0, depth=0.4)):
        alpha = _render_alpha(ctx, [obj], cam)
        ys, xs = np.nonzero(alpha > 0.5)
        assert len(xs) > 300, type(obj).__name__
        anchor = (-6.0, -14.0, 0.0) if isinstance(obj, Text) else (-6.0, -20.0, 1.0)
        c = cam.project(np.array([anchor]))[0]
        assert abs(xs.mean() - c[0]) < 25 and abs(ys.mean() - c[1]) < 25


# --------------------------------------------------------------------------- occlusion and compositing
@pytest.mark.parametrize("kind", ["uint8", "uint8_01", "bool", "float32"])
def test_player_crossing_a_logo_covers_it(ctx, kind):
    cam = CAMERAS["centred"]
    red = np.zeros((8, 8, 4), np.uint8)
    red[..., 2] = 255
    red[..., 3] = 255
    logo = Logo(red, center=(-6.0, -14.0), size=(10.0, 4.0))
    grass = (40, 140, 50)
    frame = np.empty((H, W, 3), np.uint8)
    frame[:] = grass
    c = np.round(cam.project(np.array([[-6.0, -14.0, 0.0]]))[0]).astype(int)
    player = np.zeros((H, W), bool)
    player[c[1] - 80 : c[1] + 30, c[0] - 12 : c[0] + 12] = True  # a player standing on the logo
    frame[player] = (200, 60, 20)
    matte = {"uint8": np.where(player, 0, 255).astype(np.uint8), "uint8_01": (~player).astype(np.uint8),
             "bool": ~player, "float32": (~player).astype(np.float32)}[kind]
    with Renderer(W, H, Scene([logo]), ctx=ctx) as r:
        out = r.draw(frame.copy(), cam, matte)
        alpha = r.render(cam, matte).alpha.copy()
    inner = cv2.erode(player.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    logo_px = _render_alpha(ctx, [logo], cam) > 0.99
    # the player is untouched where it stands on the logo
    assert np.count_nonzero(inner & logo_px) > 500
    np.testing.assert_array_equal(out[inner & logo_px], np.broadcast_to((200, 60, 20), (np.count_nonzero(inner & logo_px), 3)))
    # the logo covers the grass around the player
    grass_px = logo_px & ~cv2.dilate(player.astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool)
    assert np.all(out[grass_px] == (0, 0, 255))
    # soft matte: intermediate alpha on the player's outline inside the logo
    edge = logo_px & cv2.dilate(player.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool) & ~inner
    vals = alpha[edge]
    assert np.count_nonzero((vals > 10) & (vals < 245)) > 50


def test_no_matte_means_no_keying(ctx):
    cam = CAMERAS["centred"]
    logo = Logo(WHITE, center=(-6.0, -14.0), size=(10.0, 4.0))
    plain = _render_alpha(ctx, [logo], cam)
    zero = _render_alpha(ctx, [logo], cam, grass_matte=np.zeros((H, W), np.uint8))
    assert plain.max() == 1.0 and zero.max() == 0.0
    board = Billboard(position=(-8.0, -25.0), width=6.0, height=2.5)  # standing: not keyed by default
    assert _render_alpha(ctx, [board], cam, grass_matte=np.zeros((H, W), np.uint8)).max() == 1.0


def test_composite_is_premultiplied_over():
    rng = np.random.default_rng(1)
    frame = rng.integers(0, 256, (H, W, 3), dtype=np.uint8)
    bgra = np.zeros((H, W, 4), np.uint8)
    a = rng.integers(0, 256, (100, 300), dtype=np.uint8)
    bgra[200:300, 400:700, 3] = a
    for ch in range(3):
        bgra[200:300, 400:700, ch] = (rng.random((100, 300)) * a).astype(np.uint8)  # premultiplied: c <= a
    ov = Overlay(bgra, ((400, 200, 700, 300),))
    want = composite_over(frame, bgra)
    got = Compositor(W, H).composite(frame.copy(), ov)
    assert np.abs(got.astype(int) - want).max() <= 1
    # exact at the ends: transparent leaves the frame, opaque replaces it
    bgra[:] = 0
    bgra[10:20, 10:20] = (10, 20, 30, 255)
    out = Compositor(W, H).composite(frame.copy(), Overlay(bgra, ((0, 0, 64, 64),)))
    assert np.all(out[10:20, 10:20] == (10, 20, 30))
    np.testing.assert_array_equal(out[20:64], frame[20:64])
    np.testing.assert_array_equal(out[64:], frame[64:])


def test_composite_in_place_into_a_crop():
    big = np.full((H + 10, W + 20, 3), 50, np.uint8)
    view = big[5 : 5 + H, 10 : 10 + W]
    bgra = np.zeros((H, W, 4), np.uint8)
    bgra[:32, :32] = (255, 255, 255, 255)
    Compositor(W, H).composite(view, Overlay(bgra, ((0, 0, 32, 32),)))
    assert np.all(big[5:37, 10:42] == 255) and np.all(big[:5] == 50)


def test_overlay_zero_outside_rects_and_stale_frames_cleared(ctx):
    scene = default_scene()
    a, b = main_camera(W, H, pan_deg=-12), main_camera(W, H, pan_deg=10, tilt_deg=25)
    with Renderer(W, H, scene, ctx=ctx) as r1, Renderer(W, H, scene, ctx=ctx) as r2:
        r1.render(a)
        ov = r1.render(b)  # after another camera: must equal a fresh render
        fresh = r2.render(b)
        np.testing.assert_array_equal(ov.bgra, fresh.bgra)
        inside = np.zeros((H, W), bool)
        for x0, y0, x1, y1 in ov.rects:
            assert not inside[y0:y1, x0:x1].any(), "rectangles overlap"
            inside[y0:y1, x0:x1] = True
        assert ov.bgra[~inside].max() == 0 and ov.alpha.max() > 0
        lost = r1.render(None)
        assert lost.empty and lost.bgra.max() == 0



def _footprint_numpy(r: Renderer, cam: Camera):
    """The footprint's tiles, parts in view and depth range, in numpy: the
    compiled loop's reference (render.kernels.footprint_tiles)."""
    from render.camera_gl import _coeffs
    from render.renderer import TILE

    Xc = r._positions @ cam.R.T + cam.t
    z = Xc[:, 2]
    front = z > 1e-6
    with np.errstate(divide="ignore", invalid="ignore"):
        xn = Xc[:, :2] / np.where(front, z, np.nan)[:, None]
    k = _coeffs(cam.dist)
    if np.any(k):
        r2 = np.minimum((xn * xn).sum(axis=1), radial_limit(cam.dist))
        xn *= (1.0 + r2 * (k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3]))))[:, None]
    uv = np.column_stack([cam.K[0, 0] * xn[:, 0] + cam.K[0, 1] * xn[:, 1] + cam.K[0, 2], cam.K[1, 1] * xn[:, 1] + cam.K[1, 2]])
    T = uv[r._triangles]  # (M, 3, 2)
    with np.errstate(invalid="ignore"):
        lo, hi = np.floor(T.min(axis=1)) - 1.0, np.ceil(T.max(axis=1)) + 2.0
    nf = front[r._triangles].sum(axis=1)
    lo[(nf > 0) & (nf < 3)], hi[(nf > 0) & (nf < 3)] = 0.0, (r.width, r.height)  # crossing the camera plane: anything
    lo[nf == 0], hi[nf == 0] = 0.0, 0.0  # behind: nothing
    lo, hi = np.clip(lo, 0, (r.width, r.height)), np.clip(hi, 0, (r.width, r.height))
    tiles = np.zeros((r._nty, r._ntx), bool)
    vis = (hi > lo).all(axis=1)
    for (x0, y0), (x1, y1) in zip(lo[vis].astype(int) // TILE, -(-hi[vis].astype(int) // TILE)):
        tiles[y0:y1, x0:x1] = True
    visible = np.bincount(r._tri_part[vis], minlength=len(r._parts)) > 0
    return tiles, visible, max(0.5 * z[front].min(), 1e-3), max(2.0 * z[front].max(), 4.0 * max(0.5 * z[front].min(), 1e-3))


def test_footprint_is_the_tiles_the_scene_touches(ctx):
    # the compiled footprint against numpy: pans, zooms, a distorted lens, a low
    # camera with the scene around and behind it (triangles crossing the camera
    # plane cover anything), one looking away (nothing); its rectangles are
    # disjoint, aligned blocks holding every touched tile
    from render.kernels import tile_runs
    from render.renderer import BLOCK, TILE

    rng = np.random.default_rng(2)
    cams = [main_camera(W, H, pan_deg=p, tilt_deg=t, hfov_deg=f) for p, t, f in rng.uniform((-40, 8, 8), (40, 30, 70), (40, 3))]
    cams += [main_camera(W, H, pan_deg=p, dist=(-0.25, 0.05)) for p in (-20, 0, 25)]
    cams += [main_camera(W, H, center=(0.0, 0.0, 1.7), tilt_deg=5.0, hfov_deg=70.0), main_camera(W, H, pan_deg=180.0, tilt_deg=-30.0)]
    scene = default_scene()
    scene.objects.append(DistanceRing(center=(0.0, 0.0), radius=9.15))
    n_seen = n_cross = 0
    with Renderer(W, H, scene, ctx=ctx) as r:
        for cam in cams:
            fp = r.footprint(cam)
            if not fp.rects:
                assert not fp.tiles.any()
                continue
            tiles, visible, near, far = _footprint_numpy(r, cam)
            np.testing.assert_array_equal(fp.tiles, tiles)
            np.testing.assert_array_equal(fp.visible, visible)
            assert abs(fp.near - near) <= 1e-12 * near and abs(fp.far - far) <= 1e-12 * far
            cover = np.zeros((r._nty, r._ntx), bool)
            for x0, y0, x1, y1 in fp.rects:
                assert x0 % (TILE * BLOCK) == 0 and y0 % (TILE * BLOCK) == 0 and x1 <= W and y1 <= H
                assert not cover[y0 // TILE : -(-y1 // TILE), x0 // TILE : -(-x1 // TILE)].any(), "rectangles overlap"
                cover[y0 // TILE : -(-y1 // TILE), x0 // TILE : -(-x1 // TILE)] = True
            assert cover[fp.tiles].all()
            n_seen += 1
            n_cross += bool(fp.tiles.all())
        assert n_seen >= 35 and n_cross >= 1
        assert not r.footprint(cams[-1]).rects  # looking away from the pitch
    # the runs of tiles the GPU resolves: one rectangle per run of a tile row
    for _ in range(300):
        w, h = rng.integers(1, 200, 2)
        t = rng.random((-(-h // TILE), -(-w // TILE))) < rng.uniform(0, 1)
        runs = [(x0, y0, x1, y1) for x0, y0, x1, y1 in tile_runs(t, TILE, w, h).tolist()]
        want = []
        for ty, row in enumerate(t):
            edges = np.flatnonzero(np.diff(np.r_[0, row.astype(int), 0]))
            want += [(a * TILE, ty * TILE, min(b * TILE, w), min((ty + 1) * TILE, h)) for a, b in zip(edges[::2], edges[1::2])]
        assert runs == want

def test_synthetic_frame_round_trip(ctx):
    """The demo scene drawn onto a synthetic broadcast frame changes only overlay pixels."""
    cam = main_camera(W, H, pan_deg=-8, tilt_deg=20)
    frame, matte = pitch_frame(cam, W, H)
    with Renderer(W, H, ctx=ctx) as r:
        ov = r.render(cam, matte)
        out = r.compositor.composite(frame.copy(), ov)
    changed = np.any(out != frame, axis=2)
    assert changed.any() and not changed[ov.alpha == 0].any()


# --------------------------------------------------------------------------- scenes and errors
def test_default_scene_has_logo_and_offside_line():
    scene = default_scene()
    assert [o.type for o in scene.objects] == ["logo", "offside_line"]
    assert scene.objects[1].y_range == (-34.0, 34.0)


def test_a_scene_without_a_pitch_table_stands_on_the_run_s_pitch(tmp_path):
    # the offside line spans the pitch the run solves at (given or estimated),
    # not 105 x 68's 68 m: 2 m past each touchline of a 64 m wide pitch
    from arstream.pipeline.stages import load_scene_arg
    from geometry.pitch import PitchModel

    demo = default_scene((100.0, 64.0))
    assert demo.objects[1].y_range == (-32.0, 32.0) and (demo.pitch_length, demo.pitch_width) == (100.0, 64.0)
    assert load_scene_arg(None, PitchModel(110.0, 72.0)).objects[1].y_range == (-36.0, 36.0)
    bare = tmp_path / "bare.toml"
    bare.write_text('[[objects]]\ntype = "offside_line"\nx = 5.0\n')
    assert load_scene(bare, pitch=(100.0, 64.0)).objects[0].y_range == (-32.0, 32.0)
    assert load_scene(bare).objects[0].y_range == (-34.0, 34.0)
    own = tmp_path / "own.toml"
    own.write_text('[pitch]\nlength = 105.0\nwidth = 70.0\n[[objects]]\ntype = "offside_line"\nx = 5.0\n')
    assert load_scene_arg(str(own), PitchModel(100.0, 64.0)).objects[0].y_range == (-35.0, 35.0)  # (the file's table wins)


def test_toml_and_json_scenes_agree(tmp_path):
    data = {
        "pitch": {"length": 100.0, "width": 64.0},
        "render": {"samples": 2, "matte_softness": 0.5},
        "objects": [
            {"type": "offside_line", "x": 12.5, "color": "#ff0000"},
            {"type": "distance_ring", "center": [11.0, 0.0], "label": "9.15 m"},
            {"type": "arrow", "start": [0.0, 0.0], "end": [10.0, 5.0]},
            {"type": "text3d", "text": "GOAL", "position": [0.0, 30.0]},
        ],
    }
    (tmp_path / "s.json").write_text(json.dumps(data))
    (tmp_path / "s.toml").write_text(
        '[pitch]\nlength = 100.0\nwidth = 64.0\n[render]\nsamples = 2\nmatte_softness = 0.5\n'
        '[[objects]]\ntype = "offside_line"\nx = 12.5\ncolor = "#ff0000"\n'
        '[[objects]]\ntype = "distance_ring"\ncenter = [11.0, 0.0]\nlabel = "9.15 m"\n'
        '[[objects]]\ntype = "arrow"\nstart = [0.0, 0.0]\nend = [10.0, 5.0]\n'
        '[[objects]]\ntype = "text3d"\ntext = "GOAL"\nposition = [0.0, 30.0]\n'
    )
    a, b = load_scene(tmp_path / "s.json"), load_scene(tmp_path / "s.toml")
    assert a.objects == b.objects and (a.samples, a.matte_softness, a.pitch_width) == (2, 0.5, 64.0)
    assert a.objects[0].y_range == (-32.0, 32.0) and a.objects[0].color == (1.0, 0.0, 0.0, 1.0)


def _scene_error(tmp_path, text, name="bad.toml"):
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(ValueError) as exc:
        load_scene(p)
    return str(exc.value).replace(str(p), "FILE")


BAD_SCENES = [
    ('[[objects]]\ntype = "logoo"\n',
     "FILE: object 1: unknown type 'logoo' (one of: arrow, billboard, distance_ring, logo, offside_line, text, text3d)"),
    ('[[objects]]\nx = 3.0\n',
     "FILE: object 1: missing 'type' (one of: arrow, billboard, distance_ring, logo, offside_line, text, text3d)"),
    ('[[objects]]\ntype = "offside_line"\n', "FILE: object 1 (offside_line): missing required key 'x'"),
    ('[[objects]]\ntype = "offside_line"\nx = 1.0\ncolour = "#ffffff"\n',
     "FILE: object 1 (offside_line): unknown key 'colour' (allowed: color, keyed, opacity, width, x, y_range)"),
    ('[[objects]]\ntype = "offside_line"\nx = 1.0\n[[objects]]\ntype = "offside_line"\nx = "left"\n',
     "FILE: object 2 (offside_line): 'x' must be a finite number, got 'left'"),
    ('[[objects]]\ntype = "offside_line"\nx = 1.0\ncolor = [255, 0, 0]\n',
     "FILE: object 1 (offside_line): 'color' components must be in [0, 1] (not 0..255), got [255, 0, 0]"),
    ('[[objects]]\ntype = "logo"\nimage = "missing.png"\n',
     "FILE: object 1 (logo): image file not found: DIR/missing.png"),
    ('[[objects]]\ntype = "distance_ring"\ncenter = [1.0]\n',
     "FILE: object 1 (distance_ring): 'center' must be 2 numbers [x, y] in metres, got [1.0]"),
    ('[[objects]]\ntype = "billboard"\nfacing = [0.0, 0.0]\n',
     "FILE: object 1 (billboard): 'facing' must be a non-zero direction [x, y], got [0.0, 0.0]"),
    ('[[objects]]\ntype = "arrow"\nopacity = 2.0\n', "FILE: object 1 (arrow): 'opacity' must be in [0, 1], got 2"),
    ('[render]\nsamples = 3.5\n', "FILE: [render]: 'samples' must be an integer 0..16, got 3.5"),
    ('[pitch]\nlength = 200.0\n', "FILE: [pitch]: 'length' must be a number in [90, 120], got 200.0"),
    ('[camera]\nf = 1.0\n', "FILE: unknown top-level key 'camera' (allowed: objects, pitch, render)"),
    ('[[objects]]\ntype = "text"\ntext = "caf\u00e9"\n', "FILE: object 1 (text): text must be one line of printable ASCII, got 'caf\u00e9'"),
]


@pytest.mark.parametrize("text,message", BAD_SCENES)
def test_bad_scene_files_give_exact_errors(tmp_path, text, message):
    assert _scene_error(tmp_path, text) == message.replace("DIR", str(tmp_path))


def test_scene_file_level_errors(tmp_path):
    with pytest.raises(ValueError) as exc:
        load_scene(tmp_path / "nope.toml")
    assert str(exc.value) == f"scene file not found: {tmp_path / 'nope.toml'}"
    (tmp_path / "s.yaml").write_text("objects: []\n")
    with pytest.raises(ValueError) as exc:
        load_scene(tmp_path / "s.yaml")
    assert str(exc.value) == f"{tmp_path / 's.yaml'}: scene files must end in .toml or .json, got '.yaml'"
    assert _scene_error(tmp_path, '{"objects": [1,]}', "bad.json") == "FILE: invalid JSON: Expecting value (line 1, column 16)"
    msg = _scene_error(tmp_path, '[[objects]\ntype = "logo"\n')  # tomllib's own wording varies by Python version
    assert msg.startswith("FILE: invalid TOML: ") and msg.endswith("(at line 1, column 10)")


def test_missing_egl_names_the_library(monkeypatch):
    monkeypatch.setenv("GLCONTEXT_LINUX_LIBEGL", "/nonexistent/libEGL.so.1")
    with pytest.raises(GLContextError) as exc:
        create_context()
    msg = str(exc.value)
    assert "libEGL.so.1" in msg and "Mesa" in msg and "apt-get install -y libegl1 libegl-mesa0" in msg


def test_renderer_input_errors(ctx):
    with Renderer(64, 48, Scene([]), ctx=ctx) as r:
        with pytest.raises(ValueError, match=r"grass_matte must be \(48, 64\) like the frame, got \(48, 63\)"):
            r.render(main_camera(64, 48), np.zeros((48, 63), np.uint8))
        with pytest.raises(ValueError, match="grass_matte must be bool, uint8"):
            r.render(main_camera(64, 48), np.zeros((48, 64), np.int32))
        with pytest.raises(ValueError, match="camera must be a geometry.camera.Camera or None, got dict"):
            r.render({"K": None})
        assert r.render(main_camera(64, 48)).empty  # an empty scene draws nothing
        with pytest.raises(ValueError, match=r"frame must be uint8 \(48, 64, 3\) BGR, got float32 \(48, 64, 3\)"):
            r.compositor.composite(np.zeros((48, 64, 3), np.float32), r.render(None))
    with pytest.raises(ValueError, match="frame size must be 1..16384 pixels each, got 0x48"):
        Renderer(0, 48, Scene([]), ctx=ctx)


def test_camera_from_cameras_jsonl_record_renders(ctx):
    """A record of cameras.jsonl (docs/formats.md) goes straight into the renderer."""
    cam = CAMERAS["distorted"]
    rec = json.loads(json.dumps({"frame": 0, "pts": 0.0, "status": "ok", **cam.to_dict(), "confidence": 1.0}))
    cam2 = Camera.from_dict(rec)
    a = _render_alpha(ctx, [Logo(WHITE, center=(-6.0, -14.0), size=(10.0, 4.0))], cam2)
    b = _render_alpha(ctx, [Logo(WHITE, center=(-6.0, -14.0), size=(10.0, 4.0))], cam)
    np.testing.assert_array_equal(a, b)


# --------------------------------------------------------------------------- keying and the command line
def test_green_matte_keys_grass_only():
    from render.keying import green_matte

    cam = main_camera(320, 192, pan_deg=-8, tilt_deg=20)
    frame, truth = pitch_frame(cam, 320, 192)
    m = green_matte(frame)
    assert m.dtype == np.uint8 and set(np.unique(m)) <= {0, 255}
    agree = np.mean((m > 0) == (truth > 0))
    assert agree > 0.97
    with pytest.raises(ValueError, match=r"frame must be uint8 \(H, W, 3\) BGR"):
        green_matte(np.zeros((4, 4), np.uint8))


def _tiny_clip(tmp_path, n=6, size=(320, 192)):
    import av

    w, h = size
    cams = [main_camera(w, h, pan_deg=-8 + i, tilt_deg=20) for i in range(n)]
    clip = tmp_path / "clip.mp4"
    with av.open(str(clip), "w") as out:
        st = out.add_stream("libx264", rate=25)
        st.width, st.height, st.pix_fmt = w, h, "yuv420p"
        st.options = {"crf": "12", "preset": "ultrafast"}
        for cam in cams:
            vf = av.VideoFrame.from_ndarray(pitch_frame(cam, w, h)[0], format="bgr24")
            for pkt in st.encode(vf):
                out.mux(pkt)
        for pkt in st.encode(None):
            out.mux(pkt)
    recs = [{"frame": i, "pts": i / 25, "status": "ok", **c.to_dict(), "confidence": 1.0} for i, c in enumerate(cams)]
    recs[2] = {"frame": 2, "pts": 0.08, "status": "lost", "K": None, "R": None, "t": None, "H": None, "confidence": 0.0}
    (tmp_path / "cameras.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    return clip, tmp_path / "cameras.jsonl", cams


def _frames(path):
    import av

    with av.open(str(path)) as c:
        return [f.to_ndarray(format="bgr24") for f in c.decode(video=0)]


@pytest.mark.parametrize("key", ["auto", "green", "none"])
def test_arstream_render_command(tmp_path, key):
    from arstream.cli import main

    clip, cams_file, cams = _tiny_clip(tmp_path)
    out = tmp_path / "out.mp4"
    assert main(["render", str(clip), "--cameras", str(cams_file), "-o", str(out), "--key", key, "-q"]) == 0
    before, after = _frames(clip), _frames(out)
    assert len(after) == len(before) == 6
    logo = default_scene().objects[0]
    for i in range(6):  # inside the logo: drawn, except on frame 2 ("lost"), which only re-encoding touched
        mask = np.zeros((192, 320), np.uint8)
        cv2.fillConvexPoly(mask, np.round(cams[i].project(logo.outline())).astype(np.int32), 1)
        diff = np.abs(after[i].astype(int) - before[i])[mask > 0].mean()
        assert (diff < 6.0) if i == 2 else (diff > 30.0), (i, diff)


def test_arstream_render_bad_scene_exits_2(tmp_path, capsys):
    from arstream.cli import main

    (tmp_path / "s.toml").write_text('[[objects]]\ntype = "logoo"\n')
    code = main(["render", "x.mp4", "--cameras", "c.jsonl", "--scene", str(tmp_path / "s.toml"), "-o", str(tmp_path / "o.mp4")])
    assert code == 2
    assert "object 1: unknown type 'logoo'" in capsys.readouterr().err


def test_no_msaa_and_odd_frame_size(ctx):
    w, h = 641, 359
    cam = main_camera(w, h, pan_deg=-5, tilt_deg=22, hfov_deg=40, principal_point=(333.3, 170.2))
    logo = Logo(WHITE, center=(-6.0, -14.0), size=(10.0, 4.0), rotation=12.0)
    with Renderer(w, h, Scene([logo], samples=0), ctx=ctx) as r:
        assert r.samples == 0
        alpha = r.render(cam).alpha.astype(np.float64) / 255.0
    assert set(np.unique(alpha)) == {0.0, 1.0}  # no anti-aliasing without samples
    errs = _corner_errors(cam, alpha, logo.outline(), size=(w, h))
    assert len(errs) == 4 and max(errs) < 0.75  # aliased edges: half a pixel of quantisation


def test_geometry_behind_the_camera(ctx):
    """A low camera on the pitch: the offside line runs behind it; what is in front is drawn."""
    cam = main_camera(W, H, center=(0.0, 0.0, 1.7), tilt_deg=5.0, hfov_deg=70.0)
    line = OffsideLine(x=3.0, width=0.5, opacity=1.0)  # from Y = -34 (behind) to +34 (ahead)
    alpha = _render_alpha(ctx, [line], cam)
    assert np.isfinite(alpha).all() and alpha.max() == 1.0
    far_pt = cam.project(np.array([[3.0, 20.0, 0.0]]))[0]
    assert alpha[int(round(far_pt[1])), int(round(far_pt[0]))] > 0.5


def test_a_small_matte_is_stretched_over_the_frame(ctx):
    # the detector's grass mask is 8x smaller than the frame: keyed the same as
    # the same mask scaled up on the CPU (bilinear), up to the filtering's edge
    cam = CAMERAS["centred"]
    red = np.zeros((8, 8, 4), np.uint8)
    red[..., 2] = 255
    red[..., 3] = 255
    logo = Logo(red, center=(-6.0, -14.0), size=(10.0, 4.0))
    small = np.full((H // 8, W // 8), 255, np.uint8)
    c = np.round(cam.project(np.array([[-6.0, -14.0, 0.0]]))[0] / 8).astype(int)
    small[c[1] - 8 : c[1] + 3, c[0] - 2 : c[0] + 2] = 0  # a player standing on the logo
    big = cv2.resize(small, (W, H), interpolation=cv2.INTER_LINEAR)
    a_small = _render_alpha(ctx, [logo], cam, grass_matte=small)
    a_big = _render_alpha(ctx, [logo], cam, grass_matte=big)
    logo_px = _render_alpha(ctx, [logo], cam) > 0.99
    assert np.count_nonzero(logo_px & (a_big < 0.01)) > 300  # the player is cut out
    assert np.mean(np.abs(a_small - a_big)[logo_px]) < 0.02
    with Renderer(64, 48, Scene([]), ctx=ctx) as r:
        with pytest.raises(ValueError, match=r"a grass_matte smaller than the frame must have its aspect ratio: \(12, 8\) for \(48, 64\)"):
            r.render(main_camera(64, 48), np.zeros((12, 8), np.uint8))


def test_refine_matte_keys_at_full_resolution_inside_the_rectangles():
    from render.keying import refine_matte

    H_, W_ = 72, 128
    frame = np.zeros((H_, W_, 3), np.uint8)
    frame[:] = (40, 140, 50)  # grass
    frame[:12] = (60, 150, 60)  # green stands above the pitch
    frame[30:50, 40:43] = (30, 30, 200)  # a player, 3 px wide: finer than the coarse mask
    frame[20:70, 90:93] = (235, 235, 235)  # a painted line
    pitch = np.full((H_ // 8, W_ // 8), 255, np.uint8)
    pitch[:2] = 0  # the coarse pitch mask: not the stands
    lines = np.zeros((H_ // 2, W_ // 2), np.uint8)
    lines[10:35, 45] = 255  # the line's centre pixels, at half resolution
    out = np.full((H_, W_), 7, np.uint8)
    rects = [(0, 0, 64, 72), (64, 16, 128, 72)]
    refine_matte(out, rects, lambda r: frame[r[1] : r[3], r[0] : r[2]], pitch, keep=lines, keep_grow=2)
    assert np.all(out[30:50, 40:43] == 0)  # the player is cut out, to the pixel
    assert np.all(out[30:50, 36:40] == 255) and np.all(out[30:50, 43:47] == 255)
    assert np.all(out[25:65, 90:93] == 255)  # the line counts as grass
    assert np.all(out[:12, :64] == 0)  # green, but not pitch
    assert np.all(out[:16, 64:] == 7)  # outside the rectangles: untouched



@pytest.mark.parametrize("env, threads", [(None, 0), ("2", 2)])
def test_llvmpipe_rasterises_on_the_drawing_thread_unless_told(env, threads):
    """create_context sets Mesa's LP_NUM_THREADS to 0 when the environment does not
    (llvmpipe then starts no raster threads); a value the user set is kept."""
    code = (
        "import os; from render.context import create_context; c = create_context()\n"
        "names = [open(f'/proc/self/task/{t}/comm').read().strip() for t in os.listdir('/proc/self/task')]\n"
        "print(c.info['GL_RENDERER'].split()[0], os.environ['LP_NUM_THREADS'], sum(n.startswith('llvmpipe-') for n in names))"
    )
    env_vars = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    if env is not None:
        env_vars["LP_NUM_THREADS"] = env
    out = subprocess.run([sys.executable, "-c", code], env=env_vars, cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    renderer, value, n = out.stdout.split()
    assert value == str(threads)
    if renderer != "llvmpipe":
        pytest.skip(f"the raster threads are llvmpipe's; this context is {renderer}")
    assert int(n) == threads
