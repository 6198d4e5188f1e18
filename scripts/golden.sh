#!/usr/bin/env bash
# Bit-for-bit output check: renders a few small built-in sequences, runs every method, every
# preset, every post stage, the chain, extrapolation, eval and a small demo over them, and
# hashes every output (pixels and header attributes, version and timing fields aside).
#
#   scripts/golden.sh baseline [--bin BIN] [--config NAME]   record tests/golden/NAME.txt
#   scripts/golden.sh check    [--bin BIN] [--config NAME]   compare with it (exit 1 on a difference)
#   --keep DIR   keep the outputs in DIR (to diff them with idiff); default: a temporary folder
#
# BIN defaults to build/afterimage. NAME defaults to the lane width BIN reports
# (`afterimage --version`: lanes16 for an AVX-512 build, lanes8 for AVX2): outputs of another
# lane width may differ in the last bits, so each has its own baseline. An intended output
# change re-records the baseline in the same commit and says which outputs changed and why.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

usage() {
  echo "usage: scripts/golden.sh baseline|check [--bin BIN] [--config NAME] [--keep DIR]" >&2
  exit 2
}
[[ $# -ge 1 ]] || usage
mode=$1
shift
[[ $mode == baseline || $mode == check ]] || usage
bin=build/afterimage
config=""
keep=""
while [[ $# -gt 0 ]]; do
  case $1 in
    --bin) bin=$2; shift 2 ;;
    --config) config=$2; shift 2 ;;
    --keep) keep=$2; shift 2 ;;
    *) usage ;;
  esac
done
[[ -x $bin ]] || { echo "golden.sh: $bin: no such executable (build first)" >&2; exit 2; }
bin=$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")
for tool in iinfo python3; do
  command -v $tool >/dev/null || { echo "golden.sh: needs $tool (scripts/setup-deps.sh)" >&2; exit 2; }
done
if [[ -z $config ]]; then
  lanes=$("$bin" --version | sed -n 's/.* \([0-9][0-9]*\) float lanes.*/\1/p')
  [[ -n $lanes ]] || { echo "golden.sh: $bin --version names no lane width; give --config" >&2; exit 2; }
  config=lanes$lanes
fi
baseline=$root/tests/golden/$config.txt

if [[ -n $keep ]]; then
  rm -rf "$keep"
  mkdir -p "$keep"
  work=$(cd "$keep" && pwd)
else
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
R=$work/in
O=$work/out
mkdir -p "$R" "$O"
mkdir -p "$work/logs"
# Runs BIN in the background, at most `nproc` at once (each run is small and mostly process
# start-up); `barrier` waits for them and stops on the first failure, showing its output.
jobs_max=$(nproc)
n=0
ai() {
  while (($(jobs -rp | wc -l) >= jobs_max)); do wait -n; done
  n=$((n + 1))
  local log=$work/logs/$n.txt
  ("$bin" --threads 2 "$@" >"$log" 2>&1 ||
    { echo "golden.sh: failed: afterimage $*"; tail -5 "$log"; } >"$work/logs/failed.$n") &
}
barrier() {
  wait
  if compgen -G "$work/logs/failed.*" >/dev/null; then
    cat "$work"/logs/failed.* >&2
    exit 1
  fi
}

# Inputs: small renders of the scenes each family needs (the renders are outputs too).
ai render --scene motion --frames 8 --size 64x36 --out "$R/motion" --reference 4 --ssaa 4 \
  --motion-next
ai render --scene focus --frames 3 --size 64x36 --out "$R/focus" --reference 4 --reference-dof
ai render --scene sparkle --frames 3 --size 64x36 --out "$R/sparkle"
ai render --scene room_light --frames 8 --size 48x27 --path-trace --gradients --reference 8 \
  --out "$R/room"
ai render --scene penumbra --frames 6 --size 64x36 --soft-shadows --shading-cache reuse \
  --out "$R/penumbra-cache"
ai render --scene motion --frames 6 --size 64x36 --render-scale 2 --out "$R/motion-low"
barrier

# Every registered method and preset: the lists come from the registry, through --help.
presets() {  # "afterimage | none | ... (default afterimage)" after --preset in `BIN CMD --help`
  "$bin" "$1" --help | sed -n 's/^ *--preset TEXT *\([^(]*\) (default.*/\1/p' | tr -d '|'
}
stages() {  # the post stages `run --help` lists after "then"
  "$bin" run --help | sed -n 's/.*taau\[:mode\], then \(.*\)$/\1/p' | tr -d ','
}
taa_presets=$(presets resolve)
svgf_presets=$(presets denoise)
post_stages=$(stages)
for list in taa_presets svgf_presets post_stages; do
  [[ -n ${!list} ]] || { echo "golden.sh: found no $list in $bin's --help" >&2; exit 1; }
done

# The demo first: the longest run.
ai demo --out "$O/demo" --size 64x36 --frames 6 --warmup 2 --reference 4 --scenes motion \
  --cache-scenes penumbra --cache-frames 4 --extrapolate-scenes motion --effect-sections dof:focus \
  --effect-frames 2 --light-sections sparkle --denoise-scenes room_light --denoise-frames 8 \
  --denoise-spp 16 --no-video
for p in $taa_presets; do
  ai resolve --in "$R/motion" --out "$O/taa-$p" --preset "$p"
done
ai resolve --in "$R/motion" --out "$O/taa-png" --out-format png
ai resolve --in "$R/motion" --out "$O/taa-half" --half --keep-gbuffer --compression zip
ai resolve --in "$R/motion" --out "$O/taa-state" --save-state "$O/taa.state"
for u in performance balanced quality; do
  ai resolve --in "$R/motion-low" --out "$O/taau-$u" --upscale "$u"
done
for p in $svgf_presets; do
  ai denoise --in "$R/room" --out "$O/svgf-$p" --preset "$p" --taa off
done
ai denoise --in "$R/room" --out "$O/svgf-taa" --save-state "$O/svgf.state"
for s in $post_stages; do
  case $s in
    dof) in=focus ;;
    motion_blur) in=motion ;;
    *) in=sparkle ;;
  esac
  ai run --in "$R/$in" --out "$O/post-$s" --pipeline "$s"
done
ai run --in "$R/focus" --out "$O/chain" --pipeline "taa,$(echo $post_stages | tr ' ' ',')"
ai run --in "$R/motion" --out "$O/chain-taau" --pipeline "taau,motion_blur,bloom,flare,tonemap" \
  --out-format png
ai run --in "$R/room" --out "$O/chain-svgf" --pipeline svgf,taa,tonemap
ai extrapolate --in "$R/motion" --out "$O/extrapolate" --skip 1
ai extrapolate --in "$R/motion" --out "$O/interpolate" --skip 2 --interpolate --fill pushpull
barrier
# eval reads the resolves' outputs.
ai eval --out "$O/taa-afterimage" --out "$O/taa-none" --ref "$R/motion/reference" --warmup 2 \
  --json "$O/eval.json" --report "$O/eval.html"
barrier

# The manifest: one line per output file (pixels' SHA-1 and header attributes; for JSON, its
# values with timings, versions and command lines left out), sorted by path.
manifest=$work/manifest.txt
python3 - "$work" >"$manifest" <<'PY'
import hashlib, json, os, re, subprocess, sys
work = sys.argv[1]
# Fields that differ between runs or builds of the same outputs.
skip = re.compile(r"(^|_)(ms|seconds|time|timings?|version|command(_line)?|date)($|_)|per_frame_ms|elapsed")
def clean(v):
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items() if not skip.search(k)}
    if isinstance(v, list):
        return [clean(x) for x in v]
    return v
rows, images = [], []
for d, _, files in os.walk(work):
    for f in files:
        p = os.path.join(d, f)
        rel = os.path.relpath(p, work)
        if f.endswith(".exr") or f.endswith(".png") or f.endswith(".jpg"):
            images.append(p)
        elif f.endswith(".json"):
            text = json.dumps(clean(json.load(open(p))), sort_keys=True)
            rows.append(f"{rel}: " + hashlib.sha1(text.encode()).hexdigest())
        elif f.endswith(".state") or f.endswith(".alpha"):
            rows.append(f"{rel}: " + hashlib.sha1(open(p, "rb").read()).hexdigest())
# One iinfo for many images (each start of an OpenImageIO program costs ~0.5 s): its report
# is a block per file, the first line naming the file.
for i in range(0, len(images), 200):
    chunk = images[i:i + 200]
    out = subprocess.run(["iinfo", "-v", "--hash"] + chunk, capture_output=True, text=True,
                         check=True).stdout.splitlines()
    starts = []
    for p in chunk:
        hits = [k for k, l in enumerate(out) if l.startswith(p + " :")]
        if len(hits) != 1:
            sys.exit(f"golden.sh: iinfo's report names {p} {len(hits)} times")
        starts.append(hits[0])
    if starts != sorted(starts):
        sys.exit("golden.sh: iinfo reported the files out of order")
    for p, a, b in zip(chunk, starts, starts[1:] + [len(out)]):
        keep = [l.strip() for l in out[a + 1:b]
                if not re.search(r"afterimage:version|DateTime|Software", l)]
        rows.append(f"{os.path.relpath(p, work)}: " + hashlib.sha1("\n".join(keep).encode()).hexdigest())
print("\n".join(sorted(rows)))
PY

count=$(wc -l <"$manifest")
if [[ $mode == baseline ]]; then
  mkdir -p "$(dirname "$baseline")"
  cp "$manifest" "$baseline"
  echo "golden.sh: recorded $count outputs in ${baseline#$root/}"
  exit 0
fi
[[ -f $baseline ]] || {
  echo "golden.sh: no baseline ${baseline#$root/} for this build; record it with 'scripts/golden.sh baseline'" >&2
  exit 1
}
if diff -u "$baseline" "$manifest" >"$work/diff.txt"; then
  echo "golden.sh: $count outputs bit-identical to ${baseline#$root/}"
else
  echo "golden.sh: outputs differ from ${baseline#$root/} (- baseline, + this build):" >&2
  grep '^[-+][^-+]' "$work/diff.txt" >&2 || true
  [[ -n $keep ]] || echo "golden.sh: run again with --keep DIR to compare the files" >&2
  exit 1
fi
