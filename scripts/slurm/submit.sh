#!/usr/bin/env bash
# Submits a lidarsim survey to Slurm as N parts and their merge:
#   scripts/slurm/submit.sh SURVEY OUT N [CPUS_PER_PART]
# The parts run as one job array (part.sbatch), the merge as a job that
# waits for all of them (merge.sbatch, --dependency=afterok). With
# FOLLOW=1 the merge starts with the array instead (--dependency=after)
# and joins each part as it finishes (lidarsim merge --follow), so that
# little is left to copy when the last part ends; it holds its CPUs
# meanwhile, and a job that runs only if a part fails
# (--dependency=afternotok) cancels it. OUT and OUT.parts must be on a
# file system every node sees. Set LIDARSIM to the binary's path if it is
# not on the nodes' PATH; extra sbatch options (partition, account, time
# limit) go in SBATCH_OPTIONS.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
survey=$(realpath "${1:?usage: submit.sh SURVEY OUT N [CPUS_PER_PART]}")
out=$(realpath -m "${2:?usage: submit.sh SURVEY OUT N [CPUS_PER_PART]}")
n=${3:?usage: submit.sh SURVEY OUT N [CPUS_PER_PART]}
cpus=${4:-4}
# shellcheck disable=SC2086
array=$(sbatch --parsable ${SBATCH_OPTIONS:-} --array="1-$n" --cpus-per-task="$cpus" \
  "$here/part.sbatch" "$survey" "$out" "$n")
array=${array%%;*}
after=afterok
if [ -n "${FOLLOW:-}" ]; then
  after=after
fi
# shellcheck disable=SC2086
merge=$(sbatch --parsable ${SBATCH_OPTIONS:-} --dependency="$after:$array" \
  --cpus-per-task="$cpus" "$here/merge.sbatch" "$out" "$n")
merge=${merge%%;*}
if [ -n "${FOLLOW:-}" ]; then
  # A part that fails would keep the following merge waiting: cancel it.
  # shellcheck disable=SC2086
  sbatch --parsable ${SBATCH_OPTIONS:-} --dependency="afternotok:$array" \
    --kill-on-invalid-dep=yes --job-name=lidarsim-merge-cancel \
    --wrap="scancel $merge" > /dev/null
fi
echo "parts: job array $array (1-$n); merge: job $merge into $out"
