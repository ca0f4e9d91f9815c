#!/usr/bin/env bash
# Submits a lidarsim survey to Slurm as N parts and their merge:
#   scripts/slurm/submit.sh SURVEY OUT N [CPUS_PER_PART]
# The parts run as one job array (part.sbatch), the merge as a job that
# waits for all of them (merge.sbatch, --dependency=afterok). OUT and
# OUT.parts must be on a file system every node sees. Set LIDARSIM to the
# binary's path if it is not on the nodes' PATH; extra sbatch options
# (partition, account, time limit) go in SBATCH_OPTIONS.
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
# shellcheck disable=SC2086
merge=$(sbatch --parsable ${SBATCH_OPTIONS:-} --dependency="afterok:$array" \
  --cpus-per-task="$cpus" "$here/merge.sbatch" "$out" "$n")
echo "parts: job array $array (1-$n); merge: job ${merge%%;*} into $out"
