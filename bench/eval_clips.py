"""The detector on real video clips, with no region of interest: how much of each clip it
judged and on how much of that it said rain (docs/method.md, "Real clips").

    .venv/bin/python bench/eval_clips.py CLIP [CLIP ...] [--set SECTION.KEY=VALUE] [--markdown]
                                         [--passes N] [--parts SECONDS]

Real rain video from fixed cameras is rarely redistributable, so no clip ships with the
repository: point this at your own (the shared fixtures' clear clips work too). Each clip is
decoded as ``weatherd`` decodes it (PyAV) and given to the detector frame by frame at its own
frame rate; the first 90 frames (the warm-up and the first dwell) are not counted. "judged" is
the share of the counted frames whose ``state`` is ok; "rain" is the share of the judged frames
said rain; "episodes" counts the runs of rain and "longest" the longest, in frames; "typed"
is the camera's precipitation type on the frames said rain (``precipitation_type``: on a real
rain clip, every frame typed snow is a wrong answer a road operator would act on). "Pi~ p99"
and "Pi~ max" are the 99th percentile and the highest of the smoothed Pi over the judged
frames: on a dry clip, how near the decision's threshold (``decision.pi_rain``, 0.35) it came
even where it said no rain (``make eval`` prints the same for the benchmark's clear frames).

``--passes N`` plays each clip N times over (its timestamps running on) and counts the last
pass only, all of it: the detector has then learnt the whole clip (its background, the traffic
map, the rates of what recurs), which tells a part it misses for want of learning from a part
it misses for want of evidence. ``--parts S`` adds the share said rain in each S seconds.

``--draw KIND`` draws the benchmark's precipitation of that kind over every frame from
``--draw-from`` seconds on, after decoding: rain (drizzle, light, moderate or heavy:
``drivers.simulator.families.rain_streaks``, falling at ``--draw-mu`` degrees), snow drawn
anew in every frame (``snow``) or snow whose flakes persist and fall 3 pixels a frame at 480
rows (``falling-snow``), at the benchmark's density. Synthetic precipitation over a real
background: a check of the detector on views that no renderer of ours drew. The report then
adds, for each clip, the share said rain before the drawn precipitation and from a second
after it began.

``--upscale ROWS`` enlarges every decoded frame to ROWS rows (Lanczos, the width in
proportion) before the detector: a soft camera, whose finest detail spans several pixels
(a small sensor's picture scaled up, as many cheap cameras and most stock footage deliver).
What the clip shows is unchanged, but every fragment of foliage or compression is that many
times larger, so a rule set in pixels at the camera's own scale meets it at another
(docs/method.md, "Soft cameras").
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import cv2
import numpy as np
from eval_scenes import SETTLE, add_set_option, detector_params, format_table

from drivers.errors import InputError
from drivers.simulator import composite, render_falling_snow, render_snow, render_streaks
from drivers.simulator.families import RAIN_KINDS, rain_streaks, snow_flakes
from drivers.video import open_video
from hos import HosDetector, State

#: With drawn precipitation, the frames of its first second are neither before it nor
#: counted with it.
DRAWN_SETTLE_S = 1.0
#: What ``--draw`` can draw.
DRAWN_KINDS = (*RAIN_KINDS, "snow", "falling-snow")
#: Falling snow's mean fall, pixels a frame at 480 rows (the benchmark draws 1.5-7).
_FALL_PX = 3.0


class Drawn:
    """Precipitation of ``kind`` (one of :data:`DRAWN_KINDS`) drawn over frames, at the
    benchmark's density for the frame's size, from a generator seeded with ``seed``."""

    def __init__(self, kind: str, *, mu_deg: float = 85.0, seed: int = 0) -> None:
        if kind not in DRAWN_KINDS:
            raise ValueError(f"what is drawn must be one of {DRAWN_KINDS}, got {kind!r}")
        self.kind = kind
        self.mu_deg = mu_deg
        self.seed = seed
        self._rng = np.random.default_rng(seed)
        self._shape: tuple[int, int] | None = None
        self._params = None
        self._frames = 0

    def __call__(self, gray: np.ndarray) -> np.ndarray:
        """``gray`` (uint8) with the next frame of precipitation over it."""
        h, w = gray.shape
        if self._shape != (h, w):
            self._shape = (h, w)
            self._frames = 0
            if self.kind in RAIN_KINDS:
                self._params = rain_streaks(self.kind, w, h, mu_deg=self.mu_deg)
            else:
                fall = _FALL_PX if self.kind == "falling-snow" else 0.0
                self._params = snow_flakes(w, h, fall_px=fall, mu_deg=self.mu_deg)
        p = self._params
        if self.kind in RAIN_KINDS:
            layer = render_streaks((h, w), p, self._rng)
        elif self.kind == "snow":
            layer = render_snow((h, w), p, self._rng)
        else:
            layer = render_falling_snow((h, w), p, self.seed, self._frames, pool=2 * p.count + 64)
        self._frames += 1
        return composite(gray, layer)


@dataclass
class ClipResult:
    """What the detector said over one clip."""

    name: str
    size: tuple[int, int] = (0, 0)
    fps: float = 0.0
    frames: int = 0
    states: Counter = field(default_factory=Counter)
    rain: int = 0
    #: the camera's precipitation type on the judged frames said rain
    types: Counter = field(default_factory=Counter)
    episodes: int = 0
    longest: int = 0
    #: per part of the clip (``--parts``): [judged, said rain] frames
    parts: dict[int, list[int]] = field(default_factory=dict)
    #: with drawn precipitation (``--draw``): [judged, said rain] frames before it, and from
    #: ``DRAWN_SETTLE_S`` after it began
    before_drawn: list[int] = field(default_factory=lambda: [0, 0])
    with_drawn: list[int] = field(default_factory=lambda: [0, 0])
    #: the camera's precipitation type on the judged frames counted in ``with_drawn``
    drawn_types: Counter = field(default_factory=Counter)
    #: the smoothed Pi of every judged frame counted: how near the threshold a dry clip came
    pi_smoothed: list[float] = field(default_factory=list)

    @property
    def counted(self) -> int:
        return sum(self.states.values())

    @property
    def judged(self) -> int:
        return self.states[State.OK]


def upscaled_size(size: tuple[int, int], rows: int) -> tuple[int, int]:
    """(width, height) of a ``size`` frame enlarged to ``rows`` rows, the width in proportion
    (rounded to an even number, as video encoders ask)."""
    width, height = size
    return max(2, round(width * rows / height / 2) * 2), rows


def upscale(gray: np.ndarray, rows: int) -> np.ndarray:
    """``gray`` enlarged to ``rows`` rows (Lanczos): a soft camera's picture."""
    width, height = upscaled_size((gray.shape[1], gray.shape[0]), rows)
    return cv2.resize(gray, (width, height), interpolation=cv2.INTER_LANCZOS4)


def evaluate(
    path: Path,
    overrides: tuple[str, ...] = (),
    max_frames: int = 0,
    *,
    passes: int = 1,
    part_s: float = 0.0,
    draw: str | None = None,
    draw_from_s: float = 0.0,
    draw_mu_deg: float = 85.0,
    seed: int = 0,
    upscale_rows: int = 0,
) -> ClipResult:
    """Run the detector over the clip at ``path``, decoded as ``weatherd`` decodes it (PyAV,
    :func:`drivers.video.open_video`: OpenCV's capture aborts the process on some real files);
    raises :class:`drivers.errors.InputError` when it cannot be read. With ``passes`` > 1 the
    clip is played that many times to one detector and the last pass is counted, whole;
    ``part_s`` > 0 also counts each part of that many seconds (``ClipResult.parts``).
    ``draw``: one of ``DRAWN_KINDS``, drawn over the decoded frames from ``draw_from_s`` on
    (:class:`Drawn`, seeded with ``seed``). ``upscale_rows`` > 0: every frame is first
    enlarged to that many rows (:func:`upscale`)."""
    if passes < 1:
        raise ValueError("passes must be >= 1")
    drawer = None if draw is None else Drawn(draw, mu_deg=draw_mu_deg, seed=seed)
    det = HosDetector(detector_params(overrides))
    run = 0
    offset = 0.0  # seconds added to the timestamps of a pass after the first
    for n in range(passes):
        last = n == passes - 1
        end = offset
        with open_video(path) as reader:
            size = (reader.width, reader.height)
            if upscale_rows:
                size = upscaled_size(size, upscale_rows)
            res = ClipResult(path.name, fps=reader.fps, size=size)
            step = 1.0 / reader.fps if reader.fps > 0 else 0.04
            for frame in reader:
                if max_frames and res.frames >= max_frames:
                    break
                gray = upscale(frame.gray, upscale_rows) if upscale_rows else frame.gray
                drawn = drawer is not None and frame.t_s >= draw_from_s
                if drawn:
                    gray = drawer(gray)
                r = det.process(gray, frame.t_s + offset)
                end = frame.t_s + offset + step
                res.frames += 1
                if not last or (passes == 1 and res.frames <= SETTLE):
                    continue
                res.states[str(r.state)] += 1
                judged = r.state == State.OK
                said = bool(r.rain) and judged
                res.rain += said
                if said:
                    res.types[str(r.precipitation_type)] += 1
                if judged:
                    res.pi_smoothed.append(float(r.pi_smoothed))
                run = run + 1 if said else 0
                res.episodes += run == 1
                res.longest = max(res.longest, run)
                if part_s > 0:
                    part = res.parts.setdefault(int(frame.t_s // part_s), [0, 0])
                    part[0] += judged
                    part[1] += said
                if drawer is not None:
                    tally = None
                    if not drawn:
                        tally = res.before_drawn
                    elif frame.t_s >= draw_from_s + DRAWN_SETTLE_S:
                        tally = res.with_drawn
                        if judged:
                            res.drawn_types[str(r.precipitation_type)] += 1
                    if tally is not None:
                        tally[0] += judged
                        tally[1] += said
        offset = end
    return res


HEADER = [
    "clip",
    "size",
    "fps",
    "frames",
    "judged %",
    "rain %",
    "episodes",
    "longest",
    "typed",
    "Pi~ p99",
    "Pi~ max",
    "states",
]


def row(r: ClipResult) -> list[str]:
    judged = 100 * r.judged / r.counted if r.counted else 0.0
    rain = f"{100 * r.rain / r.judged:.1f}" if r.judged else "-"
    states = ", ".join(f"{k} {v}" for k, v in r.states.most_common())
    return [
        r.name,
        f"{r.size[0]}x{r.size[1]}",
        f"{r.fps:.1f}",
        str(r.frames),
        f"{judged:.0f}",
        rain,
        str(r.episodes),
        str(r.longest),
        ", ".join(f"{k} {v}" for k, v in sorted(r.types.items())) or "-",
        f"{np.percentile(r.pi_smoothed, 99):.2f}" if r.pi_smoothed else "-",
        f"{max(r.pi_smoothed):.2f}" if r.pi_smoothed else "-",
        states or f"shorter than the {SETTLE}-frame warm-up",
    ]


def _share(tally: list[int]) -> str:
    judged, said = tally
    return f"{100 * said / judged:.1f} % ({said} of {judged})" if judged else "- (none judged)"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("clips", nargs="+", type=Path, metavar="CLIP")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--max-frames", type=int, default=0, help="stop each clip after N frames")
    ap.add_argument(
        "--passes", type=int, default=1, help="play each clip N times, count the last pass"
    )
    ap.add_argument(
        "--parts", type=float, default=0.0, metavar="SECONDS", help="rain %% per part of the clip"
    )
    ap.add_argument(
        "--draw",
        choices=DRAWN_KINDS,
        default=None,
        metavar="KIND",
        help=f"draw the benchmark's precipitation over the frames: {', '.join(DRAWN_KINDS)}",
    )
    ap.add_argument(
        "--draw-from", type=float, default=0.0, metavar="SECONDS", help="drawn from then on"
    )
    ap.add_argument(
        "--draw-mu", type=float, default=85.0, metavar="DEG", help="its orientation, degrees"
    )
    ap.add_argument(
        "--upscale",
        type=int,
        default=0,
        metavar="ROWS",
        help="enlarge every frame to ROWS rows first (a soft camera)",
    )
    add_set_option(ap)
    args = ap.parse_args(argv)
    if args.upscale < 0:
        ap.error("--upscale must be >= 0")
    started = time.perf_counter()
    results, failed = [], 0
    for path in args.clips:
        try:
            results.append(
                evaluate(
                    path,
                    tuple(args.set),
                    args.max_frames,
                    passes=args.passes,
                    part_s=args.parts,
                    draw=args.draw,
                    draw_from_s=args.draw_from,
                    draw_mu_deg=args.draw_mu,
                    upscale_rows=args.upscale,
                )
            )
        except InputError as exc:
            print(f"eval_clips: {exc}", file=sys.stderr)
            failed += 1
    if results:
        print(format_table(HEADER, [row(r) for r in results], markdown=args.markdown))
        for r in results:
            if r.parts:
                parts = ", ".join(
                    f"{k * args.parts:g}-{(k + 1) * args.parts:g} s "
                    + (f"{100 * said / judged:.0f}" if judged else "-")
                    for k, (judged, said) in sorted(r.parts.items())
                )
                print(f"{r.name}, rain % of the judged frames of each {args.parts:g} s: {parts}")
        if args.draw:
            for r in results:
                print(
                    f"{r.name}, {args.draw} drawn from {args.draw_from:g} s: "
                    f"said rain before it on {_share(r.before_drawn)} of the judged frames, "
                    f"from {DRAWN_SETTLE_S:g} s after it began on {_share(r.with_drawn)}; "
                    "typed "
                    + (", ".join(f"{k} {v}" for k, v in r.drawn_types.most_common()) or "-")
                )
    print(f"{len(results)} clips in {time.perf_counter() - started:.0f} s", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
