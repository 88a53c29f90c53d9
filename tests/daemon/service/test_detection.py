from daemon.service.detection import detect_frames
from drivers.simulator import Scene, SceneParams, StreakParams
from hos import HosDetector


def _frames(n):
    params = SceneParams(cars=2, rain=StreakParams(), schedule=[0] * 62 + [1])
    scene = Scene(640, 360, seed=4, params=params)
    return [(i / 25, scene.frame(i)[0]) for i in range(n)]


def test_pipelined_results_equal_serial_results():
    frames = _frames(80)
    det = HosDetector()
    serial = [det.process(g, t).to_json() for t, g in frames]
    piped = [r.to_json() for r in detect_frames(HosDetector(), frames, pipelined=True)]
    assert piped == serial
    assert any(r["rain"] for r in piped)  # the comparison covers rain frames too
    assert [r["frame"] for r in piped] == list(range(len(frames)))


def test_closing_early_stops_the_worker():
    gen = detect_frames(HosDetector(), iter(_frames(10)))
    first = next(gen)
    gen.close()
    assert first.frame == 0


def test_empty_stream():
    assert list(detect_frames(HosDetector(), [])) == []


def test_a_change_of_resolution_starts_over_in_both_stages():
    """segment() may run frames of the new size while analyse() still has frames of the old
    one: each frame carries what its analysis needs (shape, ROI, scale)."""
    import numpy as np

    small = Scene(320, 180, seed=2, params=SceneParams(cars=1))
    big = _frames(90)
    frames = [(i / 25, small.frame(i)[0]) for i in range(70)] + [(2.8 + t, g) for t, g in big]
    roi = np.ones((180, 320), np.uint8)
    roi[:40] = 0  # no sky
    serial_det = HosDetector(roi=roi)
    serial = [serial_det.process(g, t).to_json() for t, g in frames]
    piped = [r.to_json() for r in detect_frames(HosDetector(roi=roi), frames, lookahead=3)]
    assert piped == serial
    states = [r["state"] for r in piped]
    assert states[69] == "ok" and states[70] == "warming_up"  # the new size is learnt afresh
    assert any(r["rain"] for r in piped[140:])  # and the detector works at the new size
