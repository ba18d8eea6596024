"""``arstream eval --video``: cameras judged against their own frames (no ground
truth), on frames of the committed synthetic sample with its exact cameras,
cameras known to be wrong, and a table of bad inputs."""

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from arstream.cli import main
from arstream.errors import InputError
from arstream.evaluate_video import contact_sheet, evaluate_video, format_video_table
from arstream.sink import JsonlWriter, read_jsonl
from arstream.source import VideoSource, image_frames
from arstream.support import jitter_proxy
from geometry.camera import Camera, ptr_from_rotation, rotation_from_ptr
from geometry.pitch import PitchModel

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "wide"
N = 12


@pytest.fixture(scope="module")
def truth():
    return read_jsonl(SAMPLE / "truth.jsonl")


@pytest.fixture(scope="module")
def frames_dir(tmp_path_factory):
    """The sample's first N frames as PNG files frame_0.png ... frame_11.png."""
    d = tmp_path_factory.mktemp("frames")
    with VideoSource(SAMPLE / "clip.mp4") as src:
        for f in src:
            if f.index >= N:
                break
            cv2.imwrite(str(d / f"frame_{f.index}.png"), f.image)
    return d


def write_jsonl(path, records):
    with JsonlWriter(path) as w:
        for r in records:
            w.write(r)
    return path


def moved(rec, d=(2.0, 2.0, 0.0), status=None):
    """The record's camera moved by d metres (line support 0.07-0.10 on the sample)."""
    cam = Camera.from_dict(rec)
    out = {**rec, **Camera(cam.K, cam.R, cam.t - cam.R @ np.asarray(d)).to_dict()}
    return {**out, "status": status or rec["status"]}


def lost(rec):
    return {**rec, "status": "lost", "K": None, "R": None, "t": None, "H": None}


def test_exact_cameras_on_the_sample_video(tmp_path, truth, capsys):
    out = tmp_path / "draw"
    assert main(["eval", "--video", str(SAMPLE / "clip.mp4"), "--pred", str(SAMPLE / "truth.jsonl"), "--draw-every", "10", "--draw-dir", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert (s["frames"], s["width"], s["height"], s["pixel_aspect"]) == (250, 1280, 720, 1.0)
    assert s["coverage"] == 1.0 and s["ok"] == 250 and s["missing"] == 0 and s["warnings"] == []
    # the exact cameras score 0.982-1.000 on every frame (median 0.997)
    assert s["support_frames"] == 250 and s["support_undefined"] == 0
    assert s["support_median"] >= 0.99 and s["lowest_support"][0]["share"] >= 0.95
    assert s["support_ge_0_7"] == 1.0 and s["drawn_below_0_5"] == 0 and s["drawn_below_0_5_share"] == 0.0
    # the sample's own smooth pans: 0.16 px
    assert s["jitter_triples"] == 248 and 0 < s["jitter"] < 0.5 and s["jitter_1280"] == s["jitter"]
    names = sorted(p.name for p in out.iterdir())
    assert names == ["contact_sheet.png"] + [f"frame_{i:06d}.png" for i in range(0, 250, 10)]
    assert cv2.imread(str(out / "frame_000120.png")).shape == (720, 1280, 3)
    sheet = cv2.imread(str(out / "contact_sheet.png"))
    assert sheet.shape[1] > 1280 and sheet.shape[0] > 4 * 180


def test_overlay_draws_the_projected_markings(frames_dir, truth, tmp_path):
    recs = write_jsonl(tmp_path / "c.jsonl", truth[:N])
    evaluate_video(frames_dir, read_jsonl(recs), draw_every=5, draw_dir=tmp_path / "d")
    img = cv2.imread(str(tmp_path / "d" / "frame_000005.png"))
    plain = cv2.imread(str(frames_dir / "frame_5.png"))
    changed = np.any(img != plain, axis=2)
    changed[:40] = False  # the text band
    # every changed pixel lies on a projected marking (lines 1 px wide, anti-aliased)
    cam = Camera.from_dict(truth[5])
    line_mask = np.zeros(img.shape[:2], np.uint8)
    for poly in PitchModel().polylines(0.25):
        px = cam.project(np.column_stack([poly, np.zeros(len(poly))]))
        ok = np.all(np.isfinite(px), axis=1)
        cv2.polylines(line_mask, [np.rint(px[ok] * 16).astype(np.int32)], False, 1, 5, cv2.LINE_8, shift=4)
    assert changed.sum() > 1000 and not np.any(changed & (line_mask == 0))


def test_frame_sequence_with_wrong_lost_and_missing_frames(frames_dir, truth):
    recs = [dict(r) for r in truth[:N]]
    recs[4] = moved(recs[4], status="tracked")
    recs[5] = moved(recs[5], status="tracked")
    recs[6], recs[7] = lost(recs[6]), lost(recs[7])
    del recs[8]  # frame 8: no record
    recs.append({**truth[20]})  # past the end
    s = evaluate_video(frames_dir, recs)
    assert (s.frames, s.ok, s.tracked, s.lost, s.missing, s.records) == (N, 7, 2, 2, 1, N)
    assert s.coverage == pytest.approx(9 / N)
    assert s.support_frames == 9 and s.support_ge_0_7 == pytest.approx(7 / 9)
    assert s.drawn_below_0_5 == 2 and s.drawn_below_0_5_share == pytest.approx(2 / 9)
    assert sorted(i for i, _ in s.lowest_support[:2]) == [4, 5] and s.lowest_support[1][1] < 0.15
    assert [p.index for p in s.per_frame] == list(range(N)) and s.per_frame[8].status == "missing"
    # triples with three cameras: frames 0-5 (four) and 9-11 (one)
    assert s.jitter_triples == 5
    assert any("1 records are for frames past the last one read (11): frames 20-20 ignored" in w for w in s.warnings)
    assert any("1 of 12 frames have no record" in w for w in s.warnings)
    table = format_video_table(s)
    assert "coverage                  75.0 %" in table and "(2 frames)" in table
    json.dumps(s.to_dict(per_frame=True), allow_nan=False)


def test_jitter_is_the_proxy_of_the_cameras(frames_dir, truth):
    s = evaluate_video(frames_dir, truth[:N])
    cams = [Camera.from_dict(r) for r in truth[:N]]
    assert s.jitter == jitter_proxy(cams, (1280, 720)).rms and s.jitter_triples == N - 2


def test_undefined_support_and_all_lost(frames_dir, truth):
    recs = [dict(r) for r in truth[:N]]
    cam = Camera.from_dict(recs[3])
    pan, tilt, roll = ptr_from_rotation(cam.R)
    R = rotation_from_ptr(pan, tilt - np.radians(40), roll)  # looking above the stadium
    recs[3] = {**recs[3], **Camera(cam.K, R, -R @ cam.center).to_dict()}
    s = evaluate_video(frames_dir, recs)
    assert s.support_undefined == 1 and s.support_frames == N - 1 and s.per_frame[3].share is None
    assert s.drawn_below_0_5 == 0  # undefined is neither low nor high
    s = evaluate_video(frames_dir, [lost(r) for r in truth[:N]])
    d = s.to_dict()
    assert d["coverage"] == 0.0 and d["support_median"] is None and d["support_ge_0_7"] is None
    assert d["jitter"] is None and d["jitter_1280"] is None and d["drawn_below_0_5_share"] is None
    json.dumps(d, allow_nan=False)
    assert "n/a" in format_video_table(s)


def test_squeezed_pixels(frames_dir, truth, tmp_path):
    # the frames squeezed to half their width (pixel aspect 2), with cameras whose K models it
    d = tmp_path / "squeezed"
    d.mkdir()
    recs = []
    S = np.array([[0.5, 0.0, -0.25], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # x' = (x + 0.5) / 2 - 0.5
    for i in range(N):
        img = cv2.imread(str(frames_dir / f"frame_{i}.png"))
        cv2.imwrite(str(d / f"f{i:02d}.png"), cv2.resize(img, (640, 720), interpolation=cv2.INTER_AREA))
        cam = Camera.from_dict(truth[i])
        recs.append({**truth[i], **Camera(S @ cam.K, cam.R, cam.t).to_dict()})
    plain = evaluate_video(frames_dir, truth[:N])
    s = evaluate_video(str(d / "f*.png"), recs, draw_every=6, draw_dir=tmp_path / "draw")
    assert (s.width, s.pixel_aspect) == (640, 2.0) and s.support_median > 0.9
    # the same motion, in the frame's pixels and in pixels of the 1280-wide square-pixel frame
    assert s.jitter < plain.jitter and s.jitter_1280 == pytest.approx(plain.jitter, rel=1e-9)
    assert cv2.imread(str(tmp_path / "draw" / "frame_000006.png")).shape == (720, 1280, 3)
    s1 = evaluate_video(str(d / "f*.png"), recs, pixel_aspect=1.0)
    assert s1.support_median == s.support_median
    assert s1.warnings == ("pixel aspect 1.000 given, but the cameras' K has fy/fx = 2.000: they were solved with another pixel shape (support is measured with the cameras as they are)",)


def test_still_image_and_natural_order(frames_dir, truth, tmp_path):
    one = frames_dir / "frame_3.png"
    s = evaluate_video(one, [{**truth[3], "frame": 0}])
    assert s.frames == 1 and s.support_median > 0.95 and s.jitter is None
    paths, it = image_frames(str(frames_dir / "frame_*.png"))
    assert [Path(p).name for p in paths] == [f"frame_{i}.png" for i in range(N)]
    assert [f.index for f in it] == list(range(N))
    assert image_frames(SAMPLE / "clip.mp4") is None and image_frames("rtsp://camera/stream") is None


def test_contact_sheet_keeps_an_even_spread():
    imgs = [np.full((90, 160, 3), k, np.uint8) for k in range(100)]
    sheet = contact_sheet(imgs, [str(k) for k in range(100)], max_images=10)
    assert sheet.shape[2] == 3 and sheet.shape[1] >= 160
    with pytest.raises(ValueError, match="contact_sheet: 2 labels for 100 images"):
        contact_sheet(imgs, ["a", "b"])


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda d, t: [t[0], t[1], {**t[1]}], "c.jsonl: two records for frame 1"),
        (lambda d, t: [{**t[0], "K": None}], "c.jsonl: frame 0 has status 'ok' but no camera (K, R, t)"),
        (lambda d, t: [{**t[0], "status": "great"}], "c.jsonl: frame 0 has status 'great', not 'ok', 'tracked' or 'lost'"),
        (lambda d, t: [{**t[0], "frame": "0"}], "c.jsonl: record 1 has no frame index (a non-negative integer 'frame')"),
        (lambda d, t: [[1, 2]], "c.jsonl: record 1 is not a JSON object"),
        (lambda d, t: [{**t[0], "R": np.eye(3).tolist()[:2]}], "c.jsonl: frame 0: R must be a finite 3x3 matrix, got shape (2, 3)"),
    ],
    ids=["duplicate", "ok without camera", "bad status", "no frame", "not an object", "bad R"],
)
def test_bad_records(frames_dir, truth, tmp_path, capsys, make, message):
    p = write_jsonl(tmp_path / "c.jsonl", make(frames_dir, truth))
    assert main(["eval", "--video", str(frames_dir), "--pred", str(p)]) == 2
    assert capsys.readouterr().err.strip() == f"arstream: error: {message}"


@pytest.mark.parametrize(
    "video, message",
    [
        ("missing.mp4", "input not found: {d}/missing.mp4"),
        ("missing.png", "input not found: {d}/missing.png"),
        ("nothing_*.png", "no files match {d}/nothing_*.png"),
        ("empty", "no images (.bmp, .jpeg, .jpg, .png, .tif, .tiff, .webp) in the folder {d}/empty"),
        ("notes.txt", "cannot open {d}/notes.txt as a video: "),  # then FFmpeg's reason
        ("mixed", "{d}/mixed/b.png is 64x32, the first image {d}/mixed/a.png is 1280x720"),
    ],
)
def test_bad_videos(frames_dir, truth, tmp_path, capsys, video, message):
    (tmp_path / "empty").mkdir()
    (tmp_path / "notes.txt").write_text("not a video\n")
    (tmp_path / "mixed").mkdir()
    cv2.imwrite(str(tmp_path / "mixed" / "a.png"), cv2.imread(str(frames_dir / "frame_0.png")))
    cv2.imwrite(str(tmp_path / "mixed" / "b.png"), np.zeros((32, 64, 3), np.uint8))
    p = write_jsonl(tmp_path / "c.jsonl", truth[:2])
    assert main(["eval", "--video", str(tmp_path / video), "--pred", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("arstream: error: " + message.format(d=tmp_path)) and len(err.splitlines()) == 1


def test_no_records_and_no_file(frames_dir, tmp_path, capsys):
    (tmp_path / "empty.jsonl").write_text("\n")
    assert main(["eval", "--video", str(frames_dir), "--pred", str(tmp_path / "empty.jsonl")]) == 2
    assert capsys.readouterr().err.strip() == "arstream: error: empty.jsonl has no records"
    assert main(["eval", "--video", str(frames_dir), "--pred", str(tmp_path / "none.jsonl")]) == 2
    assert "file not found" in capsys.readouterr().err
    with pytest.raises(InputError, match="drawing overlays needs a folder to write them to"):
        evaluate_video(frames_dir, [{"frame": 0, "status": "lost"}], draw_every=3)


@pytest.mark.parametrize(
    "args, message",
    [
        ([], "one of the arguments --truth --video is required"),
        (["--truth", "t.jsonl", "--video", "v.mp4"], "argument --video: not allowed with argument --truth"),
        (["--truth", "t.jsonl", "--draw-every", "5"], "--draw-every: only with --video"),
        (["--truth", "t.jsonl", "--pitch", "100x130"], "argument --pitch: pitch width must be 45-90 m (Law 1), got 130.0"),
        (["--truth", "t.jsonl", "--draw-dir", "d", "--pixel-aspect", "2"], "--draw-dir, --pixel-aspect: only with --video"),
        (["--video", "v.mp4", "--size", "640x360"], "--size: only with --truth (with --video the frames give the size)"),
        (["--video", "v.mp4", "--draw-every", "5"], "--draw-every needs --draw-dir"),
        (["--video", "v.mp4", "--draw-every", "0", "--draw-dir", "d"], "argument --draw-every: expected a positive int, got '0'"),
        (["--video", "v.mp4", "--pixel-aspect", "nan"], "argument --pixel-aspect: expected a positive float, got 'nan'"),
        (["--video", "v.mp4", "--pitch", "130x68"], "argument --pitch: pitch length must be 90-120 m (Law 1), got 130.0"),
        (["--video", "v.mp4", "--pitch", "105"], "argument --pitch: pitch must look like 105x68 (length x width, metres), got '105'"),
    ],
)
def test_usage_errors(args, message, capsys):
    with pytest.raises(SystemExit) as e:
        main(["eval", "--pred", "p.jsonl", *args])
    assert e.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(f"error: {message}")


def _drawn_still(tmp_path, pitch: PitchModel):
    """A wide view of ``pitch``'s markings painted on grass (PNG) and its camera."""
    from cameras import looking_at

    W, H = 1280, 720
    cam = looking_at((0.0, -72.0, 22.0), (8.0, 0.0, 0.0), 0.8 * W, (W, H))
    rng = np.random.default_rng(4)
    img = np.clip(np.array([60, 140, 70]) + rng.normal(0, 6, (H, W, 3)), 0, 255).astype(np.uint8)
    for poly in pitch.polylines(0.1):
        px = cam.project(np.column_stack([poly, np.zeros(len(poly))]))
        ok = np.all(np.isfinite(px), axis=1) & np.all(np.abs(px) < 4 * W, axis=1)
        if ok.sum() >= 2:
            cv2.polylines(img, [np.rint(px[ok] * 16).astype(np.int32)], False, (225, 225, 225), 2, cv2.LINE_AA, shift=4)
    path = tmp_path / "still.png"
    cv2.imwrite(str(path), img)
    return path, cam


def test_a_record_is_judged_at_its_own_pitch(tmp_path, capsys):
    # a still of a 101 x 72 m pitch and its exact camera: judged on 105 x 68's
    # markings the far ones miss their paint; with the record's own "pitch"
    # entry (what register --json writes) it is judged on the markings it was
    # made with, as with --pitch given; --pitch overrides the entry
    odd = PitchModel(101.0, 72.0)
    still, cam = _drawn_still(tmp_path, odd)
    rec = {"frame": 0, "status": "ok", **cam.to_dict(), "confidence": 1.0}
    at_default = evaluate_video(still, [rec]).support_median
    own = evaluate_video(still, [{**rec, "pitch": {"length": 101.0, "width": 72.0, "source": "estimated"}}]).support_median
    given = evaluate_video(still, [rec], pitch=odd).support_median
    assert own == given > 0.95 and at_default < own - 0.2, (at_default, own)
    assert evaluate_video(still, [{**rec, "pitch": {"length": 101.0, "width": 72.0}}], pitch=PitchModel()).support_median == at_default
    p = write_jsonl(tmp_path / "c.jsonl", [{**rec, "pitch": {"length": 101.0}}])
    assert main(["eval", "--video", str(still), "--pred", str(p)]) == 2
    assert capsys.readouterr().err.strip() == "arstream: error: c.jsonl: frame 0: a pitch entry needs a length and a width in metres ('width')"
