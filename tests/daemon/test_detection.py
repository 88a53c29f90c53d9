from daemon.detection import detect_frames
from hos import HosDetector
from hos.render import Scene, SceneParams, StreakParams


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
