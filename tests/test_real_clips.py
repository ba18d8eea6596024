"""The shared real clips through ``arstream.process`` against issue 29's
targets, with their reference cameras (tests/data/real_reference, made
independently by bench/reference_cameras.py) and ``arstream eval --video``'s
ground-truth-free figures (docs/evaluate.md). Skipped where ../shared is absent.

The targets: a camera on >= 95 % of the frames, median line support >= 0.8,
>= 90 % of the frames at >= 0.7, no frame drawn below 0.5, the mean
distance to the reference <= 5 px (of a 1280-wide frame) on >= 90 % of the
reference frames, a jitter proxy <= 1 px (of a 1280-wide frame). Where a clip does not meet one
yet (docs/real-footage.md says which and why), the test holds it to what it
does today, so that a regression fails; the bound says so.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from arstream.evaluate_video import evaluate_video
from arstream.pipeline import process
from arstream.support import jitter_proxy
from geometry.camera import Camera
from geometry.pitch import PitchModel
from arstream.evaluate import distance_1280  # (the mean distance to a reference camera, px @1280)

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data" / "real-broadcast"
REFERENCE = ROOT / "tests" / "data" / "real_reference"

sys.path.insert(0, str(ROOT / "bench"))
from real_perturbed import reencode  # noqa: E402  (another broadcast of the same match)
from real_bars import barred_copy  # noqa: E402  (the same match inside black bars)

pytestmark = [pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent"), pytest.mark.long]


def _references(item: str) -> dict[int, tuple[Camera, PitchModel]]:
    doc = json.loads((REFERENCE / f"{item}.json").read_text())
    return {e["frame"]: (Camera.from_dict(e["camera"]), PitchModel(e["pitch"]["length"], e["pitch"]["width"])) for e in doc["frames"] if "camera" in e}


def _run(tmp_path, clip: str, pitch=None):
    out = tmp_path / f"{clip}.jsonl"
    s = process(SHARED / "clips" / f"{clip}.mp4", cameras_out=out, pitch=pitch, handle_signals=False)
    records = [json.loads(line) for line in out.read_text().splitlines()]
    score = evaluate_video(SHARED / "clips" / f"{clip}.mp4", records, pitch=PitchModel(*pitch) if pitch else None)
    by_frame = {r["frame"]: r for r in records}
    dist = {}
    for frame, (ref, ref_pitch) in _references(clip).items():
        r = by_frame.get(frame)
        if r is None or r.get("K") is None:
            dist[frame] = np.inf
            continue
        got = Camera(K=np.array(r["K"]), R=np.array(r["R"]), t=np.array(r["t"]), dist=tuple(r.get("dist") or ()))
        dist[frame] = distance_1280(ref, got, (1280, 720), ref_pitch)
    return s, score, dist


def test_artificial_turf_with_its_pitch_size(tmp_path):
    # a 99.85 x 67.72 m pitch, told 100 x 68; lines of other sports across it
    s, score, dist = _run(tmp_path, "artificial_turf_multisport", (100.0, 68.0))
    assert s.frames == 176
    assert score.coverage >= 0.95, score
    assert score.support_median >= 0.8 and score.support_ge_0_7 >= 0.9, score
    assert score.drawn_below_0_5 == 0, score
    assert len(dist) == 8 and np.mean([d <= 5.0 for d in dist.values()]) >= 0.9, dist
    assert score.jitter_1280 <= 1.0, score  # (0.96 px on 2026-11-27)


def test_artificial_turf_with_no_pitch_size(tmp_path):
    # the same clip with its size unknown: its markings fit 105 x 68 poorly,
    # the scan finds 100 x 68 by line support, and the second run estimates
    # the size from there (the pitch is 99.85 x 67.72 m by the references;
    # 100.1 +- 0.2 x 66.3 +- 0.4 on 2026-11-29); judged at the size it found
    out = tmp_path / "turf.jsonl"
    clip = SHARED / "clips" / "artificial_turf_multisport.mp4"
    s = process(clip, cameras_out=out, handle_signals=False)
    scan = s.pitch["scan"]
    assert scan["sizes"][scan["chosen"]] == [100.0, 68.0], s.pitch_text
    assert s.pitch["source"] == "estimated" and 99.0 <= s.pitch["length"] <= 101.0 and 65.0 <= s.pitch["width"] <= 69.5, s.pitch_text
    records = [json.loads(line) for line in out.read_text().splitlines()]
    score = evaluate_video(clip, records, pitch=PitchModel(s.pitch["length"], s.pitch["width"]))
    assert score.coverage >= 0.95 and score.support_median >= 0.8 and score.support_ge_0_7 >= 0.9, score
    assert score.drawn_below_0_5 == 0, score
    by_frame = {r["frame"]: r for r in records}
    dist = [distance_1280(ref, Camera.from_dict(by_frame[k]), (1280, 720), ref_pitch) if by_frame[k].get("K") else np.inf for k, (ref, ref_pitch) in _references("artificial_turf_multisport").items()]
    assert len(dist) == 8 and np.mean([d <= 5.0 for d in dist]) >= 0.9, dist


def test_a_480p_penalty_view_of_the_turf_finds_its_length(tmp_path):
    # the turf clip from frame 120 (the right penalty area, then a pan to the
    # centre circle) as an 854 x 480 broadcast at crf 12, no size given. The
    # scan's medians cannot tell 100, 105 and 110 m apart (0.91 each); 100 x 68
    # lays 4504 of the points it disputes with 105 x 68 on paint to 1769, and
    # 110 x 68 1196 to 1117 (0.2 % of the points in view: a tie, not a lean
    # the same way). Held open before stop 73 (2026-12-04), the clip stayed at 105 x 68,
    # its halfway line drawn metres off its paint (reference frames 51, 25
    # and 9.6 px off; 99.9 x 67.7 m and 5.1, 4.4 and 3.0 px now)
    from real_perturbed import _cameras, reference_distances

    clip = reencode(SHARED / "clips" / "artificial_turf_multisport.mp4", tmp_path / "turf_480p_from120.mp4", (854, 480), 12, None, 120)
    out = tmp_path / "turf.jsonl"
    s = process(clip, cameras_out=out, handle_signals=False)
    scan = s.pitch["scan"]
    assert scan["sizes"][scan["chosen"]] == [100.0, 68.0], s.pitch_text
    assert 99.0 <= s.pitch["length"] <= 101.0, s.pitch_text
    records = [json.loads(line) for line in out.read_text().splitlines()]
    score = evaluate_video(clip, records, pitch=PitchModel(s.pitch["length"], s.pitch["width"]))
    assert score.coverage >= 0.95 and score.support_median >= 0.8 and score.support_ge_0_7 >= 0.9, score
    assert score.drawn_below_0_5 == 0, score
    dist = reference_distances("artificial_turf_multisport", _cameras(records), (854, 480), 120)
    # (frames 125, 150 and 175; at 480 rows the target, 5 px, is met on 2 of 3, the third at 5.1)
    assert len(dist) == 3 and np.sum(dist <= 5.0) >= 2 and np.max(dist) <= 8.0, dist


def test_israel_league_wide(tmp_path):
    s, score, dist = _run(tmp_path, "israel_league_wide")
    assert s.frames == 404
    # (78.2 % before the centre-circle view of its first 88 frames got cameras
    # from the circle's family, 2026-11-28: 99.8 %)
    assert score.coverage >= 0.95, score
    assert score.support_median >= 0.8 and score.support_ge_0_7 >= 0.9, score
    assert score.drawn_below_0_5 == 0, score
    # target: 12 of 13 within 5 px. Met (13) until stop 64 with each frame
    # windowed twice in the image motion's phase correlation (OpenCV 4.x and
    # 5.0 wrote the window into their inputs; docs/real-footage.md, "The
    # frame's own motion"). Windowed once, on any OpenCV, 2026-12-02: 11 of
    # 13 (150: 6.75 px, 225: 5.63 px, 125: 4.99 px; the tripod centre moved
    # 0.7 m along the long lens's line of sight, where focal length and
    # distance trade and the reference frames' own free centres spread over
    # 3.5 m), the jitter proxy 2.31 -> 2.04 px. Held at 10 (125 sits at the
    # bar), and none beyond 8 px: a camera off its paint, not one sliding
    # along it
    assert len(dist) == 13 and sum(d <= 5.0 for d in dist.values()) >= 10 and max(dist.values()) <= 8.0, dist
    # target 1 px: not met, held to today's level. Frames 76-86 are a whip pan
    # whose own image motion changes by up to 28 px a frame: on its own it puts
    # 1.8 px into the proxy of cameras that follow the picture exactly, whose
    # proxy is 2.4-2.5 px over the clip (bench/jitter_floor.py, frame-to-frame
    # homographies of tracked corners; 2.04 px on 2026-12-02 with each frame
    # windowed once, 2.31 on 2026-11-29, 2.39 before a centre move's step was
    # spread over the smoother's window). After it (frames 88-403, tracked
    # before too): 1.09 px on 2026-12-02 (1.03 on 2026-11-29, 1.21 before)
    assert score.jitter_1280 <= 2.7, score
    records = [json.loads(line) for line in (tmp_path / "israel_league_wide.jsonl").read_text().splitlines()]
    cams = [None if r.get("K") is None else Camera(K=np.array(r["K"]), R=np.array(r["R"]), t=np.array(r["t"]), dist=tuple(r.get("dist") or ())) for r in records[88:]]
    assert jitter_proxy(cams, (1280, 720)).rms <= 1.3


def test_israel_league_wide_at_480p(tmp_path):
    # the clip's first 200 frames (the centre-circle view, the whip pan, the
    # penalty area) as an 848 x 478 MPEG-2 broadcast at 1.5 Mbit/s, analysed
    # at its own size (Analysis's MIN_REDUCTION). The copy is the same bytes
    # on every machine and run (bench/real_perturbed.py's reencode): the
    # earlier copy, scaled by swscale and encoded by libx264 with its AVX-512
    # code, differed with the processor and from run to run, and the
    # tracker's answer with it
    # (89.5 to 97 % of the frames at >= 0.7 on copies a level apart here and
    # there: docs/real-footage.md, "The same clips through other broadcast
    # chains"). On this copy, 2026-11-28: a camera on 100 % of the frames,
    # support median 0.94, none drawn below 0.5, but 78 % of the frames at
    # >= 0.7 against the target's 90 %: held at 75 %. The frames below are
    # 26-80, the centre-circle view before the whip pan, where the far
    # touchline's paint is lost at this size and the full-size run's own
    # camera lays it on the bright edge of the grass, 5-10 px beyond its
    # paint (docs/real-footage.md, "The same clips through other broadcast
    # chains"; no reference cameras there to judge either by).
    # Jitter not held (3.4 px). At 105 x 68, as the evaluation judges it:
    # with no size its median support (0.94) starts the size scan, which
    # keeps 105 x 68 on such copies (bench/README.md "Stop 57"), at four
    # times the time
    clip = reencode(SHARED / "clips" / "israel_league_wide.mp4", tmp_path / "israel_480p.mpg", (848, 478), 1500, 200, codec="mpeg2video")
    out = tmp_path / "cameras.jsonl"
    s = process(clip, cameras_out=out, handle_signals=False, pitch=(105.0, 68.0))
    records = [json.loads(line) for line in out.read_text().splitlines()]
    score = evaluate_video(clip, records)
    assert s.frames == 200 and (score.width, score.height) == (848, 478)
    assert score.coverage >= 0.95, score
    assert score.support_median >= 0.8 and score.support_ge_0_7 >= 0.75, score
    assert score.drawn_below_0_5 == 0, score


def test_a_wrong_tripod_centre_is_left(tmp_path):
    # the clip from frame 60 (the centre-circle view through a long lens, 16
    # frames before the whip pan) as a 720p broadcast at crf 28: its first
    # frames freeze the tripod centre 5.5 m behind the full-size run's, and
    # with it every later camera bent its focal length to fit (main at
    # da37daa: none of frames 60-119 within 5 px of the full-size run's
    # camera). A free pose started from the measurement moved along its line
    # of sight finds the view's own centre at the copy's frame 55
    # (docs/real-footage.md, point 4). Both runs at 105 x 68, as the
    # distances below judge them (with no size, the clip's long-lens views
    # start the size scan, which keeps 105 x 68: the same cameras, five times
    # the time)
    from geometry.camera import Camera

    clip = reencode(SHARED / "clips" / "israel_league_wide.mp4", tmp_path / "israel_from60.mp4", (1280, 720), 28, 120, 60)
    out, full = tmp_path / "cameras.jsonl", tmp_path / "full.jsonl"
    process(clip, cameras_out=out, handle_signals=False, pitch=(105.0, 68.0))
    process(SHARED / "clips" / "israel_league_wide.mp4", cameras_out=full, max_frames=180, handle_signals=False, pitch=(105.0, 68.0))
    got = [json.loads(line) for line in out.read_text().splitlines()]
    ref = [json.loads(line) for line in full.read_text().splitlines()][60:]
    assert len(got) == len(ref) == 120
    d = [distance_1280(Camera.from_dict(r), Camera.from_dict(g), (1280, 720), PitchModel()) for g, r in zip(got[60:], ref[60:]) if g.get("K") and r.get("K")]
    # frames 60-119 of the copy: main 0 % within 5 px (median 20.6 px), 80 %
    # at stop 39 (median 3.5 px; the centres still differ by 2.7 m, about as
    # much as single views fix it along the line of sight). Since two views
    # triangulate the centre (2026-11-29) the full-size run keeps a centre
    # nearer its references over frames 104-143 (1.9, 3.7 px at frames 100
    # and 125, where the copy is 4.9 and 6.4 px off them): 57 %,
    # median 4.5 px
    assert len(d) >= 55 and np.mean(np.array(d) <= 5.0) >= 0.5 and np.median(d) < 5.0, np.round(d, 1)


def test_a_soft_copy_from_the_centre_circle_view_is_triangulated(tmp_path):
    # the clip from frame 60 (the centre-circle view through a long lens) as a
    # soft picture (a 1.2 px blur, bench/real_graphics.py's look), the
    # pitch's size given as bench/real_perturbed.py gives it. Its first views
    # freeze the tripod centre 7 m out along the line of sight (a depth-zoom
    # twin the circle's paint backs as well), and main at 13ad539 drew every
    # frame after the pan 40-60 px off (none of the 13 reference frames within
    # 5 px). Once the view has turned, the view the centre was fixed in and
    # the turned one triangulate it (Tracker._along_first_axis; today 9 of 13
    # within 5 px, median 3.8 px, the furthest 9.2 px: frames 100 and 125,
    # ramped from the frames before the move)
    from real_graphics import soft

    clip = reencode(SHARED / "clips" / "israel_league_wide.mp4", tmp_path / "israel_soft_from60.mp4", (1280, 720), 16, None, 60, look=soft)
    out = tmp_path / "cameras.jsonl"
    process(clip, cameras_out=out, handle_signals=False, pitch=(105.0, 68.0))
    got = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(got) == 344
    refs = _references("israel_league_wide")
    d = np.array([distance_1280(ref, Camera.from_dict(got[k - 60]), (1280, 720), pitch) if got[k - 60].get("K") else np.inf for k, (ref, pitch) in sorted(refs.items())])
    assert len(d) == 13 and np.median(d) < 5.0 and d.max() < 20.0, np.round(d, 1)


def test_no_frame_of_a_compressed_copy_is_drawn_below_half_support(tmp_path):
    # the clip as a 720p broadcast at crf 28 (bench/real_perturbed.py's
    # copy). The tracker judges a
    # camera on the frame at its analysis size (640 wide) and on white paint;
    # there the coarser mask backed frames 98 and 101 of this copy (101:
    # 0.62), which the whole frame puts at 0.46 and 0.33 (main at a15165b:
    # drawn). A
    # camera judged below 0.75 is judged again on the whole frame, as
    # ``arstream eval`` does, and not drawn below 0.5. At 105 x 68, as the
    # evaluation judges it (the tracker is what is tested; with no size the
    # size scan keeps 105 x 68 on this copy, at five times the time)
    clip = reencode(SHARED / "clips" / "israel_league_wide.mp4", tmp_path / "israel_crf28.mp4", (1280, 720), 28)
    out = tmp_path / "cameras.jsonl"
    process(clip, cameras_out=out, handle_signals=False, pitch=(105.0, 68.0))
    records = [json.loads(line) for line in out.read_text().splitlines()]
    score = evaluate_video(clip, records)
    assert score.frames == 404 and score.coverage >= 0.95, score
    assert score.drawn_below_0_5 == 0, score


def test_a_walk_back_after_a_centre_move_does_not_alternate_cameras(tmp_path):
    # another real clip: israel_league_wide flipped left to right (the view
    # of the other half; bench/real_perturbed.py's ``:mirror``), its first
    # 130 frames. After the whip pan the tripod centre moves 3.3 m (frame
    # 104), and the camera found there is carried back over the held frames
    # before it. The walk went on past frames whose own camera (about the
    # old centre, 5-10 px away) their paint backed a little less than the
    # walk's (by less than carry_gain), leaving them on it: the output
    # alternated between the two. Such a frame now ends the walk
    # (main at 852273f: second differences up to 38 px, the jitter proxy
    # over frames 86-110 13.1 px; 2.48 px now, where the clip itself scores
    # 2.44: the pan slowing after the whip. The whole mirrored clip 4.53 ->
    # 2.15 px, the clip itself 2.06)
    from real_perturbed import _cameras

    clip = reencode(SHARED / "clips" / "israel_league_wide.mp4", tmp_path / "israel_mirror.mp4", (1280, 720), 18, 130, mirror=True)
    out = tmp_path / "cameras.jsonl"
    process(clip, cameras_out=out, pitch=(105.0, 68.0), handle_signals=False)
    cams = _cameras([json.loads(line) for line in out.read_text().splitlines()])
    assert len(cams) == 130 and all(c is not None for c in cams[86:111])
    assert jitter_proxy(cams[86:111], (1280, 720)).rms <= 4.0


def test_an_opening_whose_circle_camera_is_weak_is_not_laid_on_other_sports_lines(tmp_path):
    # another real clip: the artificial-turf clip flipped left to right, its
    # first 60 frames, at the size its own scan estimates (100.124 x 65.997
    # m). The detector's camera of frame 0 (the centre circle with the
    # halfway line, right) has a confidence of 0.594, under init_accept; the
    # paint initialiser's own hypotheses then gave a camera 3.9 m high that
    # lays the markings on yellow and orange lines of other sports (line
    # support 0.76 at the analysis size), and the tracker followed it: frames
    # 1-14 thousands of pixels off, 15-53 20-28 px, all drawn. The detector's
    # weak camera is now judged on the paint with the paint's hypotheses
    # (0.82, the right one). Its reference frames 0, 25 and 50 within 5 px
    # (main at 9466ca7: none; frame 0 lost, 25 5 625 px off, 50 22.8 px).
    from real_perturbed import _cameras, reference_distances

    clip = reencode(SHARED / "clips" / "artificial_turf_multisport.mp4", tmp_path / "turf_mirror.mp4", (1280, 720), 18, 60, mirror=True)
    out = tmp_path / "cameras.jsonl"
    process(clip, cameras_out=out, pitch=(100.124, 65.997), handle_signals=False)
    cams = _cameras([json.loads(line) for line in out.read_text().splitlines()])
    d = reference_distances("artificial_turf_multisport", cams, (1280, 720), mirror=True)
    assert len(cams) == 60 and len(d) == 3
    assert np.all(d <= 5.0), d


def test_a_pillarboxed_clip_is_tracked_on_its_picture(tmp_path):
    # the artificial-turf clip's first 30 frames as a 4:3 picture in a 16:9
    # frame (black over the left and right 12.5 %, bench/real_bars.py): main
    # analysed the whole frame and lost frames 0-24 or, in other encodes,
    # started on a camera 850 px off (a member of the centre circle's
    # depth-zoom family twice as far away, from the ridge detector's lines),
    # which the tracker kept. Now the picture alone is analysed, and the
    # detector's camera is judged against the paint initialiser's as for a
    # still (docs/real-footage.md, points 7 and 9)
    clip = barred_copy(SHARED / "clips" / "artificial_turf_multisport.mp4", tmp_path / "turf_pillar.mp4", "pillar:0.125", frames=30)
    out = tmp_path / "cameras.jsonl"
    s = process(clip, cameras_out=out, pitch=(100.0, 68.0), handle_signals=False)
    assert s.picture == [160, 0, 1120, 720]
    got = [json.loads(line) for line in out.read_text().splitlines()]
    refs = _references("artificial_turf_multisport")
    d = [distance_1280(ref, Camera.from_dict(got[k]), (1280, 720), p) if got[k].get("K") else np.inf for k, (ref, p) in sorted(refs.items()) if k < 30]
    assert len(d) == 2 and max(d) <= 5.0, np.round(d, 1)
    assert sum(g.get("K") is not None for g in got) >= 29


def test_a_480p_still_keeps_its_markings_on_the_grass(tmp_path):
    # frame 25 of the 480p MPEG-2 copy: the centre circle, the halfway line and
    # the far-left penalty area's corner through a long lens. Of the paint
    # initialiser's hypotheses, a member of the view's depth-zoom family twice
    # too far away (f 6150 px against about 2770 at 848 wide) lays the circle
    # and the halfway line on their paint and the far touchline on the stands,
    # whose seats back it: line support 0.94 against the right member's 0.73
    # (the far touchline's paint is lost at this size), and it was picked
    # (150 px from the full-size frame's camera). 30 % of its markings in view
    # are off the grass (arstream.support.on_grass): ``register`` leaves it out
    import av

    from arstream.detect import Detector
    from arstream.initialise import initialise_from_paint, paint_view, register_frame
    from arstream.support import ON_GRASS
    from geometry.camera import Camera

    clip = reencode(SHARED / "clips" / "israel_league_wide.mp4", tmp_path / "israel_480p.mpg", (848, 478), 1500, 26, codec="mpeg2video")
    det = None
    with av.open(str(clip)) as c:
        for k, frame in enumerate(c.decode(video=0)):
            img = frame.to_ndarray(format="bgr24")
            det = det or Detector(848, 478)
            d = det.process(img)  # (the grass model learns the clip's grass frame by frame)
    assert k == 25
    view = paint_view(img, d)
    pp = np.array([423.5, 238.5])
    loose, _ = initialise_from_paint(view, (848, 478), principal_point=pp, pitch=PitchModel(), circles=d.ellipses, lines=d.lines)
    kept, sup = initialise_from_paint(view, (848, 478), principal_point=pp, pitch=PitchModel(), circles=d.ellipses, lines=d.lines, min_on_grass=ON_GRASS)
    est = register_frame(d, (848, 478), image=img)
    assert kept is not None and sup >= 0.7 and est.status == "ok", (sup, est.info)
    out = tmp_path / "full.jsonl"
    process(SHARED / "clips" / "israel_league_wide.mp4", cameras_out=out, max_frames=26, handle_signals=False)
    full = Camera.from_dict(json.loads(out.read_text().splitlines()[25]))
    S = np.diag([1280 / 848, 720 / 478, 1.0])

    def off(cam):
        return distance_1280(full, Camera(K=S @ cam.K, R=cam.R, t=cam.t, dist=cam.dist), (1280, 720), PitchModel())

    # the full-size run is itself 5-10 px off here (its far touchline on the
    # bright edge of the grass: docs/real-footage.md), and these are single
    # 480p frames, before any tracking: 20.6 px (the paint initialiser's)
    d_loose, d_kept, d_still = off(loose.camera), off(kept.camera), off(est.camera)
    assert d_loose > 100 and d_kept < 40 and d_still < 40, (d_loose, d_kept, d_still)

def test_premier_league_sequence_registered_frame_by_frame():
    # 51 frames resized from 16:9 to 512 x 512, every other one (the suite's
    # time: 1.4 s a frame) registered on its own (no tracking) on the frame
    # stretched to square pixels: coverage, support and nothing drawn below
    # 0.5 against the targets (the jitter of frames solved one by one is not
    # held to the tracker's target)
    import cv2

    from arstream.detect import detect
    from arstream.estimate import CameraEstimate
    from arstream.initialise import register_frame
    from arstream.pipeline.stages import Analysis

    folder = SHARED / "sequence-epl"
    frames = sorted(folder.glob("frame_[0-9][02468].jpg"))
    assert len(frames) == 26
    records = []
    for k, path in enumerate(frames):
        img = cv2.imread(str(path))
        H, W = img.shape[:2]
        an = Analysis(W, H, None, pixel_aspect=16 / 9)
        work = cv2.resize(img, (an.w, an.h), interpolation=cv2.INTER_CUBIC)
        est = register_frame(detect(work), (an.w, an.h), image=work)
        est = CameraEstimate(k, float(k), est.status, an.camera(est.camera), est.confidence, {}) if est.camera is not None else CameraEstimate.lost(k, float(k), reason="lost")
        records.append(est.to_record())
    score = evaluate_video(str(folder / "frame_[0-9][02468].jpg"), records, pixel_aspect=16 / 9)
    assert score.frames == 26
    # (all 51 registered one by one on 2026-11-28: 50, frame 01 lost)
    assert score.coverage >= 0.95, score
    assert score.support_median >= 0.8 and score.support_ge_0_7 >= 0.9, score
    assert score.drawn_below_0_5 == 0, score


def test_premier_league_sequence_tracked(tmp_path):
    # the folder read as a clip (25 fps), its frames' pixels 16:9 wide
    folder = SHARED / "sequence-epl"
    out = tmp_path / "epl.jsonl"
    process(folder, cameras_out=out, pixel_aspect=16 / 9, handle_signals=False)
    records = [json.loads(line) for line in out.read_text().splitlines()]
    score = evaluate_video(folder, records, pixel_aspect=16 / 9)
    # the first camera comes at frame 04 (the paint initialiser tries every 4
    # frames while lost; frames 00-01 give no camera the paint backs at the
    # tracker's 640 x 360), and is carried back over frames 00-03 while the
    # smoother still holds them (Tracker._carry_back): 92.2 -> 100 % on
    # 2026-11-28 (68.6 % when the JPEG frames' full-range levels were read as
    # video levels)
    assert score.coverage >= 0.95, score
    assert score.support_median >= 0.8 and score.support_ge_0_7 >= 0.9, score
    assert score.drawn_below_0_5 == 0, score
    assert score.jitter_1280 <= 1.0, score  # (0.63 px on 2026-11-28)
    by_frame = {r["frame"]: r for r in records}
    a = 16 / 9
    for frame, (ref, pitch) in _references("sequence_epl").items():
        r = by_frame[frame]
        assert r.get("K") is not None, frame
        got = Camera(K=np.diag([a, 1.0, 1.0]) @ np.array(r["K"]), R=np.array(r["R"]), t=np.array(r["t"]), dist=tuple(r.get("dist") or ()))
        ref = Camera(K=np.diag([a, 1.0, 1.0]) @ ref.K, R=ref.R, t=ref.t, dist=ref.dist)
        # in pixels of the frame shown 16:9 (910 x 512), then of a 1280-wide one
        d = distance_1280(ref, got, (round(512 * a), 512), pitch)
        assert d <= 5.0, (frame, d)


def test_still_agreement_flags_a_run_off_its_frames_as_stills():
    """bench/real_footage.py's check of a run against its frames registered as
    stills: a frame's own reference camera agrees with the still, another
    frame's camera and no camera do not (israel_league_wide every 100th
    frame; the stills there register at a line support of 0.95 or more)."""
    from real_footage import references, still_agreement

    refs = references("israel_league_wide")
    recs = [{"frame": k, "K": None} for k in range(404)]
    recs[200] = refs[200][0].to_dict()
    recs[300] = refs[275][0].to_dict()  # (a camera 25 frames off: the pan moved the picture)
    got = still_agreement(SHARED / "clips" / "israel_league_wide.mp4", recs, 100, PitchModel())
    off = dict(got["off"])
    assert got["checked"] == got["agree"] + len(off)
    assert 200 not in off and got["agree"] >= 1
    assert 5.0 < off[300] < float("inf")
    assert off[400] == float("inf")


def test_a_fresh_paint_camera_keeps_the_tripod_of_the_moment_before(tmp_path):
    # artificial_turf_multisport from frame 60 up-converted to 1920 x 1080
    # (crf 28, bench/real_perturbed.py): the first two frames get their camera
    # from the detector's lines (centre about (0.2, -53.8, 13.4) m); the third
    # loses its track, and the paint initialiser laid a depth-zoom twin 37 m
    # further out (f 1.7 times), drawn 742 px off the full-size run's camera
    # on the fourth frame (main at 2d90d92). With no tripod centre frozen yet,
    # the camera of a moment before is the tripod a fresh paint camera is
    # checked against: such a camera is refused until a second one agrees
    from real_perturbed import _at_1280

    # (the whole rest of the clip: x264's choices for its first frames depend on those after them)
    clip = reencode(SHARED / "clips" / "artificial_turf_multisport.mp4", tmp_path / "turf_1080.mp4", (1920, 1080), 28, None, 60)
    out, full = tmp_path / "cameras.jsonl", tmp_path / "full.jsonl"
    process(clip, cameras_out=out, pitch=(100, 68), handle_signals=False)
    process(SHARED / "clips" / "artificial_turf_multisport.mp4", cameras_out=full, pitch=(100, 68), handle_signals=False)

    def cameras(path):
        return [None if r.get("K") is None else Camera.from_dict(r) for r in (json.loads(line) for line in path.read_text().splitlines())]

    got, ref = cameras(out), cameras(full)[60:]
    assert len(got) == len(ref) == 116 and sum(c is not None for c in got) >= 110
    d = [distance_1280(r, _at_1280(g, (1920, 1080)), (1280, 720), PitchModel(100, 68)) for g, r in zip(got, ref) if g is not None and r is not None]
    # (today: none beyond 20 px, median about 2 px)
    assert max(d) < 20.0 and np.median(d) < 5.0, np.round(d, 1)
