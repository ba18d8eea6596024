"""The synthetic clips' presets (:mod:`arstream.synth`): how each one's camera
moves and how hard its frames are. Data only, without the generator's imports,
so that the CLI can list them at once (``arstream synth --help``)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Preset", "PRESETS"]


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
