"""arstream.memo: answers kept by the content of their inputs, and the
size-independent work a pitch-size scan asks for again (the paint's lines and
arcs, a circle view's family) answered the same from it."""

import threading

import numpy as np
import pytest

from arstream.memo import ContentMemo, content_key


def test_keys_follow_values_shapes_and_order():
    a = np.arange(6.0)
    assert content_key(a) == content_key(np.arange(6)) == content_key(list(range(6)))
    assert content_key(a) != content_key(a.reshape(2, 3))  # same bytes, another shape
    assert content_key(a, 1.0) != content_key(1.0, a)
    assert content_key(a) != content_key(a + 1e-12)
    img = np.zeros((4, 5, 3), np.uint8)
    other = img.copy()
    other[3, 4, 2] = 1
    assert content_key(img) == content_key(img.copy()) != content_key(other)
    # (a uint8 image and the same values as floats are different inputs)
    assert content_key(img) != content_key(img.astype(np.float64))


def test_the_least_recently_used_answer_goes_first():
    m = ContentMemo(2)
    k1, k2, k3 = (content_key(i) for i in range(3))
    m.put(k1, "one")
    m.put(k2, "two")
    assert m.get(k1) == "one"  # k1 now the most recent
    m.put(k3, "three")
    assert m.get(k2) is None and m.get(k1) == "one" and m.get(k3) == "three"
    with pytest.raises(ValueError, match="at least one"):
        ContentMemo(0)


def test_an_answer_is_computed_once_and_each_caller_gets_its_own_copy():
    m = ContentMemo(4)
    calls = []

    def compute():
        calls.append(1)
        return [np.zeros(3)]

    k = content_key(np.ones(2))
    first = m.answer(k, compute)
    first[0][:] = 7.0  # the caller changes its answer
    again = m.answer(k, compute)
    assert len(calls) == 1 and np.all(again[0] == 0.0)
    again.append("more")
    assert len(m.answer(k, compute)) == 1


def test_threads_share_one_memo():
    m = ContentMemo(8)
    out = []

    def work(i):
        for j in range(200):
            out.append(m.answer(content_key(j % 10), lambda j=j: j % 10) == j % 10)

    ts = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert len(out) == 800 and all(out)


def test_paint_lines_and_arcs_asked_again_are_the_same():
    import cv2

    from arstream.detect.paint import _paint_arcs, _paint_lines, paint_arcs, paint_lines, paint_mask

    # grass with a penalty area's front line, its arc and two sides, drawn
    img = np.zeros((720, 1280, 3), np.uint8)
    img[:] = (40, 120, 50)
    white = (225, 225, 225)
    cv2.line(img, (150, 420), (1130, 420), white, 2, cv2.LINE_AA)
    cv2.line(img, (150, 420), (60, 700), white, 2, cv2.LINE_AA)
    cv2.line(img, (1130, 420), (1230, 700), white, 2, cv2.LINE_AA)
    cv2.line(img, (300, 200), (980, 200), white, 2, cv2.LINE_AA)
    cv2.ellipse(img, (640, 420), (170, 60), 0, 180, 360, white, 2, cv2.LINE_AA)
    mask = paint_mask(img)
    lines = paint_lines(mask, img)
    again = paint_lines(mask.copy(), img.copy())
    fresh = _paint_lines(mask, img, None, 16, 1000)
    assert len(lines) == len(again) == len(fresh) >= 4
    for a, b, c in zip(lines, again, fresh):
        assert a is not b and np.array_equal(a.line, b.line) and np.array_equal(a.line, c.line) and np.array_equal(a.points, c.points)
    arcs = paint_arcs(mask, lines)
    fresh_arcs = _paint_arcs(mask, lines, 6, 2, 0.05, 0.6)
    assert len(arcs) == len(fresh_arcs) >= 1
    assert np.array_equal(arcs[0].arc.conic, fresh_arcs[0].arc.conic)
    # another frame's mask is another question
    other = mask.copy()
    other[: other.shape[0] // 2] = 0
    assert len(paint_lines(other, img)) != len(lines) or any(not np.array_equal(a.line, b.line) for a, b in zip(paint_lines(other, img), lines))


def test_a_scan_s_trackers_share_each_frame_s_paint_view():
    from arstream.initialise import FrameViews

    img = np.zeros((72, 128, 3), np.uint8)
    img[:] = (40, 120, 50)
    img[30:32, 10:110] = 230
    views = FrameViews()
    a = views.view(7, img, None, 2)
    assert views.view(7, img, None, 2) is a  # a second tracker, the same frame
    assert views.view(7, img, None, 1) is not a  # another reach is another view
    assert views.view(8, img, None, 2) is not a  # the next frame
    again = img.copy()
    b = views.view(8, again, None, 2)
    assert b is not a and views.view(8, again, None, 2) is b  # (another image under one number: a source started again)
    assert np.array_equal(b.mask, a.mask) and np.array_equal(b.bright, a.bright)
