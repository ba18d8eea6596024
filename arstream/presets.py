"""The synthetic clips' presets (:mod:`arstream.synth`): how each one's camera
moves and how hard its frames are. Data only, without the generator's imports,
so that the CLI can list them at once (``arstream synth --help``).

Two families: :data:`PRESETS`, the five clean presets the benchmarks run on,
and :data:`REAL_PRESETS`, whose clips add what real television shows (see
:class:`RealPreset` and ``docs/synth.md``). :data:`ALL_PRESETS` holds both."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Preset", "PRESETS", "RealPreset", "REAL_PRESETS", "ALL_PRESETS"]


@dataclass(frozen=True)
class Preset:
    """How a synthetic clip's camera moves and how hard its frames are.

    Attributes
    ----------
    name, description : str
    f_range : (lo, hi) focal length as multiples of the image width
    zoom_period : float, seconds of one zoom in-out cycle (0: slow drift only)
    target_x, target_y : (lo, hi) metres, where the play (camera target) roams
    fast_pans : float, expected fast pans per 10 s
    blur : float, motion-blur strength (exposure as a share of the frame interval)
    white_kit : bool, the away team wears white
    stadium_shadow : bool, a hard roof shadow across the pitch
    k1 : float, radial distortion coefficient at the wide end (scaled by 1/zoom)
    pp_offset : (dx, dy) principal point offset from the image centre, pixels
    cut : (start share of the clip, seconds) of a cut to a crowd close-up, or None
    noise : float, sensor noise sigma (grey levels)
    """

    name: str
    description: str
    f_range: tuple[float, float] = (1.0, 1.5)
    zoom_period: float = 0.0
    target_x: tuple[float, float] = (-22.0, 22.0)
    target_y: tuple[float, float] = (-12.0, 12.0)
    fast_pans: float = 0.0
    blur: float = 0.5
    white_kit: bool = False
    stadium_shadow: bool = False
    k1: float = 0.0
    pp_offset: tuple[float, float] = (0.0, 0.0)
    cut: tuple[float, float] | None = None
    noise: float = 2.0


PRESETS: dict[str, Preset] = {
    p.name: p
    for p in (
        Preset("wide", "wide view around the centre circle, gentle pans", f_range=(1.0, 1.4)),
        Preset("zoom", "zooms in and out (f 1.0-3.5 x width) around midfield", f_range=(1.0, 3.5), zoom_period=7.0, target_x=(-15.0, 15.0), target_y=(-8.0, 8.0)),
        Preset(
            "hard",
            "fast pans with strong blur, white away kit, stadium shadow, radial distortion, off-centre principal point",
            f_range=(1.0, 2.2),
            zoom_period=9.0,
            target_x=(-28.0, 28.0),
            fast_pans=3.0,
            blur=1.0,
            white_kit=True,
            stadium_shadow=True,
            k1=-0.06,
            pp_offset=(7.0, -5.0),
            noise=3.0,
        ),
        Preset("penalty", "play in the right penalty area; the centre circle mostly out of view", f_range=(1.5, 2.4), target_x=(34.0, 44.0), target_y=(-14.0, 14.0)),
        Preset("cut", "wide play with a one-second cut to a crowd close-up (no pitch) and back", f_range=(1.0, 1.5), cut=(0.4, 1.0)),
    )
}


@dataclass(frozen=True)
class RealPreset(Preset):
    """A preset of the realistic family: a :class:`Preset`'s camera motion plus
    the look of real broadcast frames. Each seed draws its own look within
    these ranges (:class:`arstream.synth.Look`: pitch size, distortion, grass,
    paint, shadow, other sports' lines, on-screen graphics).

    Attributes (besides :class:`Preset`'s; ``k1`` is unused: see ``k1_wide``)
    ----------
    camera_x : (lo, hi) metres, camera centre along the touchlines (0: halfway line)
    camera_back : (lo, hi) metres behind the near touchline
    camera_height : (lo, hi) metres above the pitch
    k1_wide : (lo, hi) radial distortion k1 at the wide end (f = f_range[0] x
        width); it fades as 1/f when the lens zooms in
    pitch_length, pitch_width : (lo, hi) metres, the pitch size is drawn per seed
    turf : "grass" (mowing stripes: bands, checks or diagonals) or "artificial"
        (even bright green, no stripes)
    shadow : float, probability of a hard sun / roof shadow across the pitch
    other_lines : float, probability of coloured lines of other sports
    graphics : "tv" (score graphic, channel logo, caption, sometimes a black box)
        or "stream" (a logo, a black box, a watermark)
    size : (width, height) stored pixels, the default frame size
    pixel_aspect : (p, q), the stored pixels' sample aspect ratio p:q (64:45 is
        anamorphic 16:9 PAL at 720x576); written into the video stream
    crf : int, the default x264 quality (higher: stronger compression)
    """

    camera_x: tuple[float, float] = (-8.0, 8.0)
    camera_back: tuple[float, float] = (15.0, 40.0)
    camera_height: tuple[float, float] = (15.0, 35.0)
    k1_wide: tuple[float, float] = (-0.1, -0.03)
    pitch_length: tuple[float, float] = (100.0, 110.0)
    pitch_width: tuple[float, float] = (64.0, 75.0)
    turf: str = "grass"
    shadow: float = 0.6
    other_lines: float = 0.15
    graphics: str = "tv"
    size: tuple[int, int] = (1280, 720)
    pixel_aspect: tuple[int, int] = (1, 1)
    crf: int = 28


# the main camera frames the far touchline near the top of the picture: play on
# the near half (target_y < 0) is centred, the far half shows less stand
_REAL_WIDE = dict(f_range=(0.85, 1.5), target_x=(-30.0, 30.0), target_y=(-20.0, 6.0), noise=2.5, blur=0.25)

REAL_PRESETS: dict[str, RealPreset] = {
    p.name: p
    for p in (
        RealPreset("real-wide", "like television: wide main camera near the halfway line, 15-35 m up, barrel distortion, worn faint lines, shadow, graphics, 720p crf 28", **_REAL_WIDE),
        RealPreset(
            "real-penalty", "like television: play in a penalty area, tighter zoom, the centre circle out of view", f_range=(1.2, 2.2), target_x=(33.0, 44.0), target_y=(-14.0, 14.0), noise=2.5
        ),
        RealPreset(
            "real-multisport",
            "a lower-league stream: artificial turf with yellow/orange/blue lines of other sports, a lower camera, logo and black box",
            f_range=(0.8, 1.2),
            target_x=(-25.0, 25.0),
            target_y=(-12.0, 12.0),
            camera_back=(4.0, 15.0),
            camera_height=(8.0, 18.0),
            turf="artificial",
            shadow=0.0,
            other_lines=1.0,
            graphics="stream",
            crf=30,
            noise=3.0,
        ),
        RealPreset("real-sd", "real-wide in standard definition: 720x576 anamorphic (pixel aspect 64:45), crf 30", **_REAL_WIDE, size=(720, 576), pixel_aspect=(64, 45), crf=30),
    )
}

ALL_PRESETS: dict[str, Preset] = {**PRESETS, **REAL_PRESETS}
