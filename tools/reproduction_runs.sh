#!/usr/bin/env bash
# The reproduction's long runs between machines (docs/reproduction.md, "Runs between machines"; issue 35). A folder
# outside the repository is lost when the machine changes, so each working stretch ends by saving every run's last
# checkpoint, its output (the series the analysis needs) and its configuration into the repository, and the next
# one starts by restoring them and resuming the sweeps:
#   tools/reproduction_runs.sh save       # runs/<sweep>/<point>/ -> docs/reproduction/runs/<sweep>/<point>/
#   tools/reproduction_runs.sh restore    # the reverse, then:
#   capsflow sweep examples/sweeps/reproduction_set_a.toml --local --jobs 3 --threads 1   # and reproduction.toml
# Stop the sweeps first (Ctrl-C or SIGINT: each run checkpoints); a run still writing is refused (its lock file).
set -euo pipefail
cd "$(dirname "$0")/.."
sweeps=(reproduction_set_a reproduction)
store=docs/reproduction/runs
files=(config.toml output.checkpoint.h5 output.h5 output.xdmf run.log)
case "${1:-}" in
  save)   from=runs; to=$store ;;
  restore) from=$store; to=runs ;;
  *) echo "usage: $0 save|restore" >&2; exit 2 ;;
esac
for s in "${sweeps[@]}"; do
  [ -d "$from/$s" ] || continue
  for d in "$from/$s"/*/; do
    p=$(basename "$d")
    if [ -e "$d/output.lock" ] && [ "$1" = save ]; then
      echo "$0: $d is still running (output.lock); stop its sweep first (Ctrl-C)" >&2
      exit 2
    fi
    mkdir -p "$to/$s/$p"
    for f in "${files[@]}"; do
      [ -e "$d/$f" ] && cp -p "$d/$f" "$to/$s/$p/$f.tmp.$$" && mv -f "$to/$s/$p/$f.tmp.$$" "$to/$s/$p/$f"
    done
    echo "$1: $s/$p"
  done
done
