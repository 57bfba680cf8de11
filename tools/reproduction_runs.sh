#!/usr/bin/env bash
# The reproduction's long runs between machines (docs/reproduction.md, "Runs between machines"; issue 35). A folder
# outside the repository is lost when the machine changes, so each working stretch ends by saving every run's last
# checkpoint, its output (the series the analysis needs) and its configuration into the repository, and the next
# one starts by restoring them and resuming the sweeps. The output goes through tools/run_store.py: the store keeps
# the output as first saved and, at each later save, a part with only the records written since (git keeps every
# version of a changed file whole: re-committing a 70 MB output at each save is what made a submission too big):
#   tools/reproduction_runs.sh save       # runs/<sweep>/<point>/ -> docs/reproduction/runs/<sweep>/<point>/
#   tools/reproduction_runs.sh restore    # the reverse, then:
#   capsflow sweep examples/sweeps/reproduction_c_seed2.toml --local --jobs 1 --threads 1   # and every sweep below
# (set A and set C, seed 1, are done at 1000 strain; set C's mixture with seed 2 and set A at X_f 0.2 / 0.8 go on.)
# Stop the sweeps first (Ctrl-C or SIGINT: each run checkpoints); a run still writing is refused (its output.lock,
# read as capsflow reads it: tools/run_marker.py; a lock left by a run that was killed is said and ignored).
# Once both sets have run to the window's end:
#   tools/reproduction_runs.sh analyze    # runs/<sweep> -> docs/figures/reproduction/{set_a,steady}: the analysis
#                                         # over [500, 1000], its figures, and docs/reproduction.md's claims tables
#                                         # (between the markers) and claims:from line regenerated from both
#   tools/reproduction_runs.sh figures [set_a|steady]...   # only the figures (PNG), redrawn from the committed
#                                         # analyses, no runs needed (default: both): after a change of the drawing
# (CAPSFLOW: the capsflow to use, default build/release/capsflow; WINDOW: default 500:1000; FIGDIR and PAGE: where the
# analyses and the page are, for a trial run elsewhere.) Nothing is replaced unless every analysis succeeded.
set -euo pipefail
cd "$(dirname "$0")/.."
# The first two are the analysed sets (A and C, seed 1); the others are saved and restored alike.
sweeps=(reproduction_set_a reproduction reproduction_c_seed2 reproduction_set_a_xf reproduction_set_a_presets)
store=docs/reproduction/runs
files=(config.toml output.checkpoint.h5 output.xdmf run.log result)   # output.h5: tools/run_store.py
py=/usr/bin/python3
[ -x "$py" ] || py=python3

analyze() {
  local bin=${CAPSFLOW:-build/release/capsflow} window=${WINDOW:-500:1000}
  local figdir=${FIGDIR:-docs/figures/reproduction} page=${PAGE:-docs/reproduction.md}
  local names=(set_a steady) work
  work=$(mktemp -d)
  trap 'rm -rf "$work"' RETURN
  # Into a scratch folder first: a failed analysis (a run short of the window) leaves the committed ones as they are.
  for i in 0 1; do
    "$bin" analyze "runs/${sweeps[$i]}" --window "$window" --out "$work/${names[$i]}"
    "$bin" figures "$work/${names[$i]}" --out "$work/${names[$i]}" --force
    rm -f "$work/${names[$i]}"/*.svg "$work/${names[$i]}"/isolated.csv "$work/${names[$i]}"/pairs.csv
  done
  mkdir -p "$figdir"
  for n in "${names[@]}"; do
    rm -rf "${figdir:?}/$n.tmp.$$"
    cp -r "$work/$n" "$figdir/$n.tmp.$$"
    rm -rf "${figdir:?}/$n"
    mv "$figdir/$n.tmp.$$" "$figdir/$n"
  done
  PYTHONPATH=python "$py" tools/reproduction_claims.py "$figdir/set_a" "$figdir/steady" --write "$page"
  echo "analyze: $figdir/set_a and $figdir/steady over [$window]; $page's claims tables regenerated"
}

# The committed analyses' PNG figures redrawn by the current `capsflow figures` (what the docs show of the study).
figures() {
  local bin=${CAPSFLOW:-build/release/capsflow} figdir=${FIGDIR:-docs/figures/reproduction} work n
  local names=("$@")
  [ ${#names[@]} -gt 0 ] || names=(set_a steady)
  work=$(mktemp -d)
  trap 'rm -rf "$work"' RETURN
  for n in "${names[@]}"; do
    "$bin" figures "$figdir/$n" --out "$work/$n"   # a scratch folder: the SVGs stay out of the repository
    cp "$work/$n"/*.png "$figdir/$n/"
  done
  echo "figures: ${names[*]} redrawn in $figdir"
}

case "${1:-}" in
  save)   from=runs; to=$store ;;
  restore) from=$store; to=runs ;;
  analyze) analyze; exit 0 ;;
  figures) shift; figures "$@"; exit 0 ;;
  *) echo "usage: $0 save|restore|analyze|figures [NAME]..." >&2; exit 2 ;;
esac
for s in "${sweeps[@]}"; do
  [ -d "$from/$s" ] || continue
  for d in "$from/$s"/*/; do
    p=$(basename "$d")
    # The point's run folder (what a save reads, a restore writes) read as capsflow reads its lock: a live run stops
    # the command before anything of the point is copied; a killed run's leftover lock is said and ignored.
    run=$d
    [ "$1" = save ] || run="$to/$s/$p"
    "$py" tools/run_store.py lock-status "$run" || exit 2
    mkdir -p "$to/$s/$p"
    # The output first: a save whose check fails (or a refused restore) copies nothing else.
    "$py" tools/run_store.py "$1" "$d" "$to/$s/$p"
    for f in "${files[@]}"; do
      [ -e "$d/$f" ] && cp -p "$d/$f" "$to/$s/$p/$f.tmp.$$" && mv -f "$to/$s/$p/$f.tmp.$$" "$to/$s/$p/$f"
    done
    echo "$1: $s/$p"
  done
done
if [ "$1" = save ]; then
  # What this save adds to the next submission (a submission carries at most 256 MiB of diffs: docs/reproduction.md).
  new=$(git status --porcelain --untracked-files=all -- "$store" | awk '{print $2}' | xargs -r du -cb | tail -n 1 | cut -f1)
  echo "save: ${new:-0} bytes new or changed under $store since the last commit"
fi
