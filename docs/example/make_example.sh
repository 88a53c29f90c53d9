#!/bin/sh
# The worked example of docs/offline.md: a short rainy log and a matching reference gauge,
# generated (nothing binary is committed). Usage: docs/example/make_example.sh [DIR]
# (default build/example); `make example` runs it with the project's virtualenv.
#
#   street.mp4   8 minutes of the demo street at 320x180, 10 fps: one minute each of rain
#                intensity 0, 0.5, 1, 1.5, 2, 2.5, 1, 0 (weatherd simulate)
#   truth.csv    what the simulator drew, frame by frame
#   street.mcap  the daemon's pipeline over it, from 2026-03-01 12:00:00 UTC (weatherd replay)
#   gauge.csv    one-minute amounts derived from the truth: 4 mm/h at intensity 1, 10 % error
#
# About a minute on two cores.
set -eu
here=$(dirname "$0")
out=${1:-build/example}
start=2026-03-01T12:00:00Z
mkdir -p "$out"
weatherd simulate "$out/street.mp4" --seconds 480 --fps 10 --width 320 --height 180 \
    --weather rain --intensity 0,0.5,1,1.5,2,2.5,1,0 --seed 1 --truth "$out/truth.csv"
weatherd replay "$out/street.mp4" --out "$out/street.mcap" --start "$start" --fps 10 \
    --camera street
python "$here/gauge_from_truth.py" "$out/truth.csv" --start "$start" --interval 60 \
    > "$out/gauge.csv"
echo "example written to $out: street.mcap (the log), gauge.csv (the reference)"
