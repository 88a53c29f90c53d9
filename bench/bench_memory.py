"""The daemon's memory on an edge box: one camera at 960x540, and where the megabytes go.

Runs the real ``weatherd run`` (Zenoh on loopback, MCAP recording to a temporary folder) with one
960x540 camera, samples its resident set (VmRSS) once a second, and reports the peak. Two
cameras are tried, the demo street (``demo:``) and a ``file:`` camera looping an H.264 clip
(PyAV decoding, as with a real camera), each on the numpy path (``HOS_JIT=0``, what the systemd
unit runs) and with the compiled kernels (numba, what ``make run`` runs). The goal: one camera
at 960x540 under 250 MB on the deployed path.

Then the imports, one at a time in a fresh interpreter, with the resident set each adds, so that
a regression says where it comes from.

    python bench/bench_memory.py              # 40 s per run
    python bench/bench_memory.py --seconds 15 # quicker
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from drivers.simulator import Scene, SceneParams, StreakParams, write_video  # noqa: E402

RESULTS = REPO / "bench" / "results"
IMPORTS = (
    "numpy",
    "cv2",
    "av",
    "zenoh",
    "mcap",
    "pydantic",
    "hos",
    "daemon.config",
    "daemon.recording.recorder",
    "daemon.transport.publisher",
    "daemon.service.app",
    "numba",
)
CONFIG = """
[site]
id = "membench"
[zenoh]
listen = ["tcp/127.0.0.1:{port}"]
[recording]
dir = "{rec}"
[[camera]]
id = "cam"
source = "{source}"
width = 960
height = 540
fps = 25.0
loop = true
"""


def rss_kib(pid: int) -> int | None:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def run_daemon(source: str, jit: bool, seconds: float, workdir: Path, port: int) -> dict:
    config = workdir / f"run-{port}.toml"
    rec = workdir / f"rec-{port}"
    config.write_text(CONFIG.format(port=port, rec=rec, source=source))
    env = {**os.environ, "HOS_JIT": "1" if jit else "0", "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "daemon.cli", "run", "--config", str(config)],
        cwd=REPO,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    samples = []
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and proc.poll() is None:
        time.sleep(1.0)
        kib = rss_kib(proc.pid)
        if kib:
            samples.append(kib / 1024)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    if proc.returncode != 0 or not samples:
        raise SystemExit(f"weatherd run failed ({proc.returncode}): {err[-500:]}")
    return {
        "source": source.split(":")[0] + ":",
        "path": "numba" if jit else "numpy",
        "seconds": seconds,
        "peak_mib": round(max(samples), 1),
        "final_mib": round(samples[-1], 1),
    }


def import_costs() -> list[dict]:
    code = (
        "import importlib, json, sys\n"
        "def rss():\n"
        "    for line in open('/proc/self/status'):\n"
        "        if line.startswith('VmRSS:'): return int(line.split()[1]) / 1024\n"
        "out = [{'module': 'python', 'adds_mib': round(rss(), 1)}]\n"
        "for m in sys.argv[1:]:\n"
        "    before = rss(); importlib.import_module(m)\n"
        "    out.append({'module': m, 'adds_mib': round(rss() - before, 1)})\n"
        "print(json.dumps(out))\n"
    )
    env = {**os.environ, "HOS_JIT": "0", "PYTHONPATH": str(REPO)}
    out = subprocess.run(
        [sys.executable, "-c", code, *IMPORTS], env=env, capture_output=True, text=True, check=True
    ).stdout
    return json.loads(out)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=40.0, help="length of each run")
    args = parser.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        clip = work / "street-960x540.mp4"
        scene = Scene(960, 540, seed=3, params=SceneParams.busy(rain=StreakParams(count=500)))
        write_video(clip, (scene.frame(i)[0] for i in range(250)), fps=25)
        sources = ("demo:", f"file:{clip}")
        for i, (source, jit) in enumerate((s, j) for s in sources for j in (False, True)):
            row = run_daemon(source, jit, args.seconds, work, port=17600 + i)
            rows.append(row)
            print(
                f"{row['source']:6s} {row['path']:5s} path: peak {row['peak_mib']} MiB, "
                f"final {row['final_mib']} MiB over {row['seconds']:.0f} s",
                flush=True,
            )
    imports = import_costs()
    print("imports, resident set added (numpy path):")
    for item in imports:
        print(f"  {item['module']:28s} {item['adds_mib']:6.1f} MiB")
    (RESULTS / "memory.json").write_text(json.dumps({"runs": rows, "imports": imports}, indent=1))
    deployed = [r for r in rows if r["path"] == "numpy"]
    worst = max(r["peak_mib"] for r in deployed)
    print(f"deployed path (HOS_JIT=0), worst peak {worst} MiB: goal 250 MB (238 MiB)")
    return 0 if worst * 2**20 < 250e6 else 1


if __name__ == "__main__":
    sys.exit(main())
