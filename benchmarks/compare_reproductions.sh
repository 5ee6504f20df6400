#!/usr/bin/env bash
# benchmarks/compare_reproductions.sh BASE NEW: do two `thermocue reproduce figure9` outputs carry identical answers?
# Ignores only what differs between two runs of the same commit: wall-clock timestamps, paths,
# durations, and the PDF's creation date. Exit 0 when identical.
set -u
base=$1; new=$2; rc=0
norm() {  # file dir
  sed -e "s#$2#OUT#g" "$1" \
    | sed -E 's/[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9:.]+Z?/TIME/g; s/[0-9]{4}-[0-9]{2}-[0-9]{2}_[0-9]{2}h[0-9]{2}\.[0-9]{2}\.[0-9]{3}/DATE/g' \
    | sed -E 's/"(seconds|sessions_s|analysis_s|scenarios_s|study_s|total_s|t_wall|wall_s|elapsed_s)": [0-9.e+-]+/"\1": X/g'
}
cd "$base"
while IFS= read -r f; do
  case "$f" in *.png|*.pdf) continue;; esac
  if [ ! -f "$new/$f" ]; then echo "MISSING in new: $f"; rc=1; continue; fi
  if ! diff -q <(norm "$base/$f" "$base") <(norm "$new/$f" "$new") >/dev/null; then
    echo "DIFFERS: $f"; diff <(norm "$base/$f" "$base") <(norm "$new/$f" "$new") | head -6; rc=1
  fi
done < <(find . -type f | sed 's#^\./##' | sort)
(cd "$new" && find . -type f | sed 's#^\./##' | sort) | while IFS= read -r f; do
  [ -f "$base/$f" ] || echo "NEW file only in new: $f"
done
[ $rc = 0 ] && echo "IDENTICAL (timestamps, paths, durations ignored; png/pdf skipped)"
exit $rc
