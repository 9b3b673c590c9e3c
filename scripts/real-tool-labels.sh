#!/usr/bin/env bash
# The synthetic room with labels made by the real tools, trained and scored on the
# schedule of pipeline/synthetic.toml (docs/training-notes.md, "Real-tool labels").
#
# Usage: scripts/real-tool-labels.sh [--tiny] [--pairs N] [--until STAGE] [--pipeline FILE] WORK
#
#   1. render   `pl2map run pipeline/synthetic.toml --work WORK --until synth`: the room
#               of the default pipeline (300 frames, seed 0) in WORK/synth/synthroom
#               (--tiny: pipeline/synthetic-tiny.toml's 24 + 8 frames, a quick check);
#   2. tools    scripts/limap-tiny.py WORK/synth/synthroom WORK/tools in the LIMAP venv:
#               pycolmap SIFT, matching of each image with its N = 20 nearest (--pairs N,
#               like hloc's pairs_from_poses; --pairs 0: exhaustive, 8.6 x the pairs of the
#               room) and point triangulation with the known poses, then LIMAP 2.0's LSD
#               + exhaustive line matching with each image's neighbours + line
#               triangulation; skipped when WORK/tools/report.json is newer than the
#               render and was made with the same matching;
#   3. pipeline `pl2map run pipeline/synthetic-real-tools.toml --work WORK` with
#               PL2MAP_SYNTH_ROOM and PL2MAP_REAL_TOOLS set: ingest -> import -> refine
#               -> shard -> train -> score (up-to-date stages are skipped; --until stops
#               earlier, --pipeline runs another file with the same variables);
#   then prints the tools' counts, the import's detector check and the score table
#   (WORK/score/summary.md).
#
# Needs: pl2map (PL2MAP, else `pl2map` on PATH, else $CARGO_TARGET_DIR/release/pl2map,
# else target/release/pl2map; `cargo build --release --locked -p cli`) and the LIMAP venv
# of scripts/setup-python.sh ($HOME/.cache/pl2map-rs/limap-venv: pylimap 2.0.0, pycolmap
# 4.2.0, pytlsd 0.0.2), or its python in PL2MAP_LIMAP_PYTHON. Heavy steps run under
# `nice -n ${PL2MAP_NICE:-10}`.
#
# Times on a 2-core AMD EPYC shared with another training run (upper bounds), default
# room: render 68 s; tools 2409 s (SIFT 114 s, matching 2,316 pairs 164 s, point
# triangulation 29 s, LIMAP metainfos 2 s, LSD 19 s, line triangulation 2077 s); ingest
# 2 s, import 4 s, refine 4 s, shard 2 s, train 1522 s, score 27 s: about 67 min. The
# tiny scene: under 2 minutes up to the shards. On a 2-core Intel Xeon VM (2026-12-04, shared
# with one other training): render 31 s, tools 922 s (line triangulation 776 s), train 973 s.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(dirname "$here")"
tiny=0
pairs=20
until_stage=""
pipeline="$repo/pipeline/synthetic-real-tools.toml"
work=""
while [ $# -gt 0 ]; do
  case "$1" in
    --tiny) tiny=1 ;;
    --pairs) pairs="${2:?--pairs needs a number}"; shift ;;
    --until) until_stage="${2:?--until needs a stage}"; shift ;;
    --pipeline) pipeline="${2:?--pipeline needs a file}"; shift ;;
    -h|--help) sed -n '2,/^set -euo/{/^#/p}' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "real-tool-labels: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) [ -z "$work" ] || { echo "real-tool-labels: one WORK folder only" >&2; exit 2; }
       work="$1" ;;
  esac
  shift
done
[ -n "$work" ] || { echo "usage: $0 [--tiny] [--pairs N] [--until STAGE] [--pipeline FILE] WORK" >&2; exit 2; }
case "$pairs" in ''|*[!0-9]*) echo "real-tool-labels: --pairs takes a number" >&2; exit 2 ;; esac
mkdir -p "$work"
work="$(cd "$work" && pwd)"

if [ -n "${PL2MAP:-}" ]; then
  pl2map="$PL2MAP"
elif command -v pl2map >/dev/null 2>&1; then
  pl2map="$(command -v pl2map)"
elif [ -x "${CARGO_TARGET_DIR:-$repo/target}/release/pl2map" ]; then
  pl2map="${CARGO_TARGET_DIR:-$repo/target}/release/pl2map"
else
  echo "real-tool-labels: no pl2map binary: build it (cargo build --release --locked -p cli)" \
       "or set PL2MAP" >&2
  exit 1
fi
python="${PL2MAP_LIMAP_PYTHON:-$HOME/.cache/pl2map-rs/limap-venv/bin/python}"
if ! [ -x "$python" ] || ! "$python" -c "import limap, pycolmap, pytlsd" 2>/dev/null; then
  echo "real-tool-labels: no LIMAP venv with limap, pycolmap and pytlsd at $python:" \
       "run scripts/setup-python.sh (it makes $HOME/.cache/pl2map-rs/limap-venv)" \
       "or set PL2MAP_LIMAP_PYTHON" >&2
  exit 1
fi
nice=(nice -n "${PL2MAP_NICE:-10}")

step() { echo "== real-tool-labels: $*" >&2; }
elapsed() { echo "$(( $(date +%s) - $1 )) s"; }

# 1. The room of the default pipeline (its own stage record: up to date on a rerun).
render_pipeline="$repo/pipeline/synthetic.toml"
[ "$tiny" = 1 ] && render_pipeline="$repo/pipeline/synthetic-tiny.toml"
step "render ($(basename "$render_pipeline") [synth]) into $work/synth"
t=$(date +%s)
"${nice[@]}" "$pl2map" run "$render_pipeline" --work "$work" --until synth
step "render: $(elapsed "$t")"
room="$work/synth/synthroom"

# 2. The real tools, unless their report is newer than the render and made with the
# same matching.
tools="$work/tools"
if [ "$pairs" = 0 ]; then
  matching="exhaustive"; pair_args=()
else
  matching="pairs_from_poses $pairs"; pair_args=(--pairs-from-poses "$pairs")
fi
made_with="$("$python" -c 'import json, sys; print(json.load(open(sys.argv[1])).get("matching", "exhaustive"))' \
  "$tools/report.json" 2>/dev/null || true)"
if [ -f "$tools/report.json" ] && [ "$tools/report.json" -nt "$work/synth/stage.json" ] &&
   [ "$made_with" = "$matching" ]; then
  step "tools: $tools/report.json is up to date, skipped"
else
  step "tools (pycolmap $("$python" -c 'import pycolmap; print(pycolmap.__version__)'), LIMAP $("$python" -c 'import limap; print(limap.__version__)')) into $tools"
  t=$(date +%s)
  rm -f "$tools/report.json"
  "${nice[@]}" "$python" "$here/limap-tiny.py" "${pair_args[@]}" "$room" "$tools"
  step "tools: $(elapsed "$t")"
fi

# 3. ingest -> import -> refine -> shard -> train -> score.
step "pipeline $(basename "$pipeline") --work $work"
t=$(date +%s)
until_args=()
[ -n "$until_stage" ] && until_args=(--until "$until_stage")
PL2MAP_SYNTH_ROOM="$room" PL2MAP_REAL_TOOLS="$tools" \
  "${nice[@]}" "$pl2map" run "$pipeline" --work "$work" "${until_args[@]}"
step "pipeline: $(elapsed "$t")"

# What the run made: the tools' counts, the detector check, the score table.
"$python" - "$tools/report.json" "$work/import/import_report.json" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"tools: pycolmap {r['versions']['pycolmap']}, LIMAP {r['versions']['limap']}, "
      f"{r.get('matching', 'exhaustive')} matching: "
      f"{len(r['images'])} images, {r['points3d']} points "
      f"({r['observations']} observations, mean track length {r['mean_track_length']:.2f}), "
      f"{len(r['lines3d'])} line tracks ({r['tracks_in_4_images']} in >= 4 images); "
      + ", ".join(f"{k} {v:.0f} s" for k, v in r["times_s"].items()))
try:
    d = json.load(open(sys.argv[2])).get("detector_check")
except FileNotFoundError:
    d = None
if d:
    print(f"import detector check ({d['front_end']} + {d['line_detector']}, "
          f"{len(d['images'])} images, {d['radius_px']} px): keypoints "
          f"{d['keypoints_matched']} / {d['keypoints']} = {d['keypoint_rate']:.3f} "
          f"(min {d['min_keypoint_rate']}), segments {d['segments_matched']} / "
          f"{d['segments']} = {d['segment_rate']:.3f} (min {d['min_segment_rate']}): "
          f"{d['decision']}")
EOF
# (A score table of an earlier run is not shown after --until.)
if [ -z "$until_stage" ] || [ "$until_stage" = score ] && [ -f "$work/score/summary.md" ]; then
  cat "$work/score/summary.md"
fi
