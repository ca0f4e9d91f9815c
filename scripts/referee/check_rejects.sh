#!/usr/bin/env bash
# Shows that the referee of sampling changes
# (crates/lidarsim/tests/integration/canopy_marches.rs) fails on a change
# that moves the physics: each patch here is applied to a copy of HEAD in
# a temporary worktree, and the referee must fail on it. Exits non-zero if
# it passes on any. Not part of scripts/test.sh (a build of its own per
# patch, about 4 minutes on 2 cores).
# Usage: scripts/referee/check_rejects.sh [PATCH...]   (default: every *.patch here)
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
patches=("$@")
[ ${#patches[@]} -gt 0 ] || patches=(scripts/referee/*.patch)
work=$(mktemp -d)
trap 'git -C "$root" worktree remove --force "$work/tree" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
status=0
for patch in "${patches[@]}"; do
  git worktree add --quiet --detach "$work/tree" HEAD
  git -C "$work/tree" apply "$root/$patch"
  echo "== $patch"
  if (cd "$work/tree" && CARGO_TARGET_DIR="$work/target" CARGO_INCREMENTAL=0 \
      cargo test -q -p lidarsim --test integration \
      canopy_marches::the_pulse_march_keeps_the_reference_statistics -- --nocapture) \
      > "$work/log" 2>&1; then
    echo "the referee PASSED a change it must reject:"; status=1
  else
    echo "rejected, as it must be:"
  fi
  grep -E "^(statistic|points|pulses|first|canopy|trunk|vegetation|mean|return|beyond)" "$work/log" || tail -20 "$work/log"
  git worktree remove --force "$work/tree"
done
exit $status
