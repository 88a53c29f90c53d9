"""How many sites can one Zenoh router carry to a ``weather/**`` subscriber, and how fast?

One router process, N simulated sites, one subscriber on ``weather/**``, all on 127.0.0.1.
Each site is a real :class:`daemon.transport.publisher.ZenohPublisher` in client mode (its own
session, TCP connection, liveliness token and queryable, as in the field) publishing a ~1 KB
``weather.state/1``-like message at 1 Hz on ``weather/site-XXX/state``; the sites are spread
over a few publisher processes (both cores busy) and their phases spread over the second.
The publish time (``time.time_ns()`` just before ``put``) is in the payload; the subscriber
stamps the reception with the same clock, so latency = receive - publish, router hop included.

    python bench/bench_zenoh_sites.py                       # 200 sites, 20 s
    python bench/bench_zenoh_sites.py --sites 50 --seconds 5

Prints a table and one JSON line. Delivery counts the messages of the measured seconds only
(after every session is connected); messages are sent with zenoh's default congestion
control for puts (drop when a queue stays full), so a shortfall would show overload.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.zenoh_tools import RouterProcess, SubscriberProcess, free_port  # noqa: E402

CLK_TCK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def site_name(i: int) -> str:
    return f"site-{i:03d}"


def state_message(site: str, seq: int, pad: str) -> dict:
    """A ``weather.state/1``-shaped message; ``pad`` brings it to the wanted size."""
    now_ns = time.time_ns()
    return {
        "schema": "weather.state/1",
        "site": site,
        "seq": seq,
        "t_ns": now_ns,
        "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(now_ns / 1e9)),
        "precipitation": True,
        "precipitation_type": "rain",
        "rain_rate_mm_h": 3.2,
        "rain_rate_source": "camera",
        "intensity": "moderate",
        "wawa": 62,
        "metar": "RA",
        "visibility_m": 4200.0,
        "cameras": {
            "cam0": {
                "rain": True,
                "state": "ok",
                "pi": 0.41,
                "mu_deg": 87.5,
                "sigma_deg": 6.1,
                "R": 0.018,
                "fps": 12.5,
            },
        },
        "calibration": {"model": "power", "a": 210.0, "b": 1.1, "n": 48, "r2": 0.81},
        "sources": ["camera:cam0", "gauge:g0"],
        "pad": pad,
    }


# -- publisher process ---------------------------------------------------------------------------


def run_publishers(
    endpoint: str, first: int, count: int, total: int, seconds: int, start_at: float, size: int
) -> None:
    """Child program: ``count`` of ``total`` sites from index ``first``; stats on stdout."""
    from daemon.transport.publisher import ZenohPublisher, encode_message, zenoh_config

    logging.basicConfig(level=logging.ERROR)  # open retries are counted, not logged

    config = zenoh_config(mode="client", connect=[endpoint])
    sites = [site_name(i) for i in range(first, first + count)]
    pubs = [ZenohPublisher(s, config, retry_initial_s=0.2, retry_max_s=2.0) for s in sites]
    base = len(encode_message(state_message(sites[0], 0, "")))
    pad = "x" * max(0, size - base)
    lateness_s = []
    try:
        for pub in pubs:
            pub.start()
        deadline = time.monotonic() + 60
        while not all(p.connected for p in pubs) and time.monotonic() < deadline:
            time.sleep(0.05)
        print(json.dumps({"ready": sum(p.connected for p in pubs)}), flush=True)
        # site g of the fleet publishes at start_at + k + g / total: phases spread evenly
        schedule = sorted(
            (start_at + k + (first + j) / total, j, k) for j in range(count) for k in range(seconds)
        )
        for t_due, j, k in schedule:
            wait = t_due - time.time()
            if wait > 0:
                time.sleep(wait)
            lateness_s.append(time.time() - t_due)
            pubs[j].put("state", state_message(sites[j], k, pad))
        time.sleep(1.0)  # let the last messages leave
        stats = [p.stats() for p in pubs]
    finally:
        for pub in pubs:
            pub.close()
    print(
        json.dumps(
            {
                "puts": sum(s["puts"] for s in stats),
                "put_errors": sum(s["put_errors"] for s in stats),
                "unsent": sum(s["unsent"] for s in stats),
                "open_retries": sum(s["open_attempts"] - s["opens"] for s in stats),
                "max_lateness_s": max(lateness_s, default=0.0),
                "payload_bytes": len(encode_message(state_message(sites[0], 0, pad))),
            }
        ),
        flush=True,
    )


# -- measurement ---------------------------------------------------------------------------------


def cpu_s(pid: int) -> float:
    """User + system CPU time of a process, seconds (Linux ``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return math.nan


def percentile(sorted_values: list[float], q: float) -> float:
    if not sorted_values:
        return math.nan
    i = min(len(sorted_values) - 1, max(0, math.ceil(q / 100 * len(sorted_values)) - 1))
    return sorted_values[i]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sites", type=int, default=200)
    parser.add_argument("--seconds", type=int, default=20)
    parser.add_argument(
        "--procs",
        type=int,
        default=max(2, min(4, os.cpu_count() or 2)),
        help="publisher processes (default: 2 to 4, one per core)",
    )
    parser.add_argument("--size", type=int, default=1024, help="payload size, bytes")
    parser.add_argument(
        "--router-json5",
        default=None,
        help="extra router config, e.g. '{transport: {unicast: {accept_pending: 500}}}'",
    )
    args = parser.parse_args()

    port = free_port()
    with (
        RouterProcess(port, config_json5=args.router_json5) as router,
        SubscriberProcess(router.endpoint) as sub,
    ):
        start_at = time.time() + 8.0 + args.sites * 0.02  # time for every session to open
        shares = [
            args.sites // args.procs + (i < args.sites % args.procs) for i in range(args.procs)
        ]
        procs = []
        first = 0
        for share in shares:
            procs.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        __file__,
                        "_publish",
                        router.endpoint,
                        str(first),
                        str(share),
                        str(args.sites),
                        str(args.seconds),
                        repr(start_at),
                        str(args.size),
                    ],
                    stdout=subprocess.PIPE,
                    text=True,
                    cwd=REPO,
                )
            )
            first += share
        ready = sum(json.loads(p.stdout.readline())["ready"] for p in procs)
        late_start = time.time() > start_at
        time.sleep(max(0.0, start_at - time.time()))
        cpu0 = {
            "router": cpu_s(router.proc.pid),
            "subscriber": cpu_s(sub.proc.pid),
            "publishers": sum(cpu_s(p.pid) for p in procs),
        }
        wall0 = time.time()
        time.sleep(args.seconds)
        cpu1 = {
            "router": cpu_s(router.proc.pid),
            "subscriber": cpu_s(sub.proc.pid),
            "publishers": sum(cpu_s(p.pid) for p in procs),
        }
        wall = time.time() - wall0
        router_rss = rss_mib(router.proc.pid)
        pub_stats = [
            json.loads(p.communicate(timeout=120)[0].strip().splitlines()[-1]) for p in procs
        ]
        time.sleep(0.5)
        messages = sub.messages()

    latencies, seen = [], set()
    for m in messages:
        value = m["json"]
        if m["liveliness"] or not isinstance(value, dict) or "seq" not in value:
            continue
        seen.add((value["site"], value["seq"]))
        latencies.append((m["recv_ns"] - value["t_ns"]) / 1e6)
    latencies.sort()
    expected = args.sites * args.seconds
    result = {
        "bench": "zenoh_sites",
        "sites": args.sites,
        "seconds": args.seconds,
        "publisher_procs": args.procs,
        "payload_bytes": pub_stats[0]["payload_bytes"],
        "sessions_connected": ready,
        "expected": expected,
        "delivered": len(seen),
        "duplicates": len(latencies) - len(seen),
        "delivered_ratio": round(len(seen) / expected, 5),
        "latency_ms": {
            q: round(percentile(latencies, v), 3)
            for q, v in (("p50", 50), ("p95", 95), ("p99", 99), ("max", 100))
        },
        "put_errors": sum(s["put_errors"] for s in pub_stats),
        "open_retries": sum(s["open_retries"] for s in pub_stats),
        "publisher_max_lateness_ms": round(max(s["max_lateness_s"] for s in pub_stats) * 1e3, 1),
        "cpu_pct": {k: round(100 * (cpu1[k] - cpu0[k]) / wall, 1) for k in cpu0},
        "router_rss_mib": round(router_rss, 1),
        "late_start": late_start,
        "cpus": os.cpu_count(),
        "zenoh": _zenoh_version(),
    }
    print_table(result)
    print(json.dumps(result))


def _zenoh_version() -> str:
    from importlib.metadata import version

    return version("eclipse-zenoh")


def print_table(r: dict) -> None:
    lat = r["latency_ms"]
    rows = [
        (
            "sites x seconds",
            f"{r['sites']} x {r['seconds']} s at 1 Hz, "
            f"{r['payload_bytes']} B, {r['publisher_procs']} publisher procs",
        ),
        (
            "sessions connected",
            f"{r['sessions_connected']} / {r['sites']} ({r['open_retries']} open retries)",
        ),
        (
            "delivered / expected",
            f"{r['delivered']} / {r['expected']} ({100 * r['delivered_ratio']:.2f} %)",
        ),
        ("latency p50 / p95", f"{lat['p50']:.2f} / {lat['p95']:.2f} ms"),
        ("latency p99 / max", f"{lat['p99']:.2f} / {lat['max']:.2f} ms"),
        ("publisher lateness max", f"{r['publisher_max_lateness_ms']:.1f} ms"),
        (
            "CPU router / sub / pubs",
            "{router} / {subscriber} / {publishers} %".format(**r["cpu_pct"]),
        ),
        ("router RSS", f"{r['router_rss_mib']:.1f} MiB"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "_publish":
        endpoint, first, count, total, seconds, start_at, size = sys.argv[2:9]
        run_publishers(
            endpoint, int(first), int(count), int(total), int(seconds), float(start_at), int(size)
        )
    else:
        main()
