//! The Slurm scripts (`scripts/slurm`): `submit.sh` submits the parts as a
//! job array and the merge as a dependent job; run here by a stand-in
//! `sbatch` that runs each array task in turn, they give the files of the
//! unsplit run.

use std::path::{Path, PathBuf};

use crate::kit::{GOOD, temp};

/// A stand-in for `sbatch`: runs the script at once, once per task of
/// `--array=1-N` with `SLURM_ARRAY_TASK_ID` set, after checking that a
/// `--dependency=afterok:ID` or `after:ID` names a job it ran; prints the
/// job id (`--parsable`). A job `--dependency=afternotok:ID` on a job that
/// succeeded never runs (`--kill-on-invalid-dep`): it is listed in
/// `never`.
const SBATCH: &str = r#"#!/usr/bin/env bash
set -euo pipefail
array=""; dep=""; notok=""; cpus=1; args=()
for a in "$@"; do
  case "$a" in
    --array=*) array=${a#--array=} ;;
    --dependency=afterok:*) dep=${a#--dependency=afterok:} ;;
    --dependency=after:*) dep=${a#--dependency=after:} ;;
    --dependency=afternotok:*) notok=${a#--dependency=afternotok:} ;;
    --cpus-per-task=*) cpus=${a#--cpus-per-task=} ;;
    --parsable) ;;
    --*) ;;
    *) args+=("$a") ;;
  esac
done
state=${FAKE_SLURM_STATE:?}
if [ -n "$dep" ] && ! grep -qx "$dep" "$state/done"; then
  echo "dependency $dep did not complete" >&2; exit 1
fi
id=$(( $(wc -l < "$state/done") + 100 ))
if [ -n "$notok" ]; then
  grep -qx "$notok" "$state/done" || { echo "no job $notok" >&2; exit 1; }
  echo "$id $*" >> "$state/never"
  echo "$id" >> "$state/done"
  echo "$id"
  exit 0
fi
if [ -n "$array" ]; then
  for k in $(seq "${array%-*}" "${array#*-}"); do
    SLURM_ARRAY_TASK_ID=$k SLURM_CPUS_PER_TASK=$cpus bash "${args[@]}" >> "$state/log" 2>&1
  done
else
  SLURM_CPUS_PER_TASK=$cpus bash "${args[@]}" >> "$state/log" 2>&1
fi
echo "$id" >> "$state/done"
echo "$id"
"#;

fn scripts() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/slurm")
}

#[test]
fn the_slurm_scripts_run_parts_and_merge_into_the_unsplit_run() {
    submit_and_compare("slurm", false);
}

/// With FOLLOW=1 the merge starts with the array (`after`, not
/// `afterok`) and follows the parts (`lidarsim merge --follow`); a job
/// that would cancel it if a part failed is submitted beside it.
#[test]
fn a_following_slurm_merge_is_the_unsplit_run() {
    let (log, never) = submit_and_compare("slurm-follow", true);
    assert!(log.contains("part 3 of 3 joined"), "{log}");
    assert!(
        never.contains("--dependency=afternotok:100") && never.contains("scancel 101"),
        "{never}"
    );
}

/// Submits a three-line survey as three parts and their merge through
/// `submit.sh` (`FOLLOW` set when `follow`), under the stand-in `sbatch`,
/// and checks the merged files against an unsplit run; returns the jobs'
/// log and the jobs that never ran.
fn submit_and_compare(name: &str, follow: bool) -> (String, String) {
    let dir = temp(name);
    let survey = dir.join("survey.toml");
    // Three lines: three parts of whole lines.
    let text = GOOD.replace(
        "[output]",
        "[[flight_line]]\nstart_m = [40.0, 10.0, 300.0]\nend_m = [40.0, -10.0, 300.0]\n\
         speed_mps = 50.0\n\n[[flight_line]]\nstart_m = [80.0, -10.0, 300.0]\n\
         end_m = [80.0, 10.0, 300.0]\nspeed_mps = 50.0\n\n[output]",
    );
    std::fs::write(&survey, text).unwrap();
    let fake = dir.join("bin");
    std::fs::create_dir_all(&fake).unwrap();
    let sbatch = fake.join("sbatch");
    std::fs::write(&sbatch, SBATCH).unwrap();
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&sbatch, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let state = dir.join("state");
    std::fs::create_dir_all(&state).unwrap();
    std::fs::write(state.join("done"), "").unwrap();
    let path = format!(
        "{}:{}",
        fake.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = dir.join("campaign");
    let mut submit = std::process::Command::new("bash");
    if follow {
        submit.env("FOLLOW", "1");
    } else {
        submit.env_remove("FOLLOW");
    }
    let o = submit
        .arg(scripts().join("submit.sh"))
        .arg(&survey)
        .arg(&out)
        .args(["3", "1"])
        .env("PATH", path)
        .env("FAKE_SLURM_STATE", &state)
        .env("LIDARSIM", env!("CARGO_BIN_EXE_lidarsim"))
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .output()
        .unwrap();
    let log = std::fs::read_to_string(state.join("log")).unwrap_or_default();
    assert!(
        o.status.success(),
        "{}\n{log}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(String::from_utf8_lossy(&o.stdout).contains("job array 100"));
    // The parts' directory is removed after the merge.
    assert!(!dir.join("campaign.parts").exists(), "{log}");
    let whole = dir.join("whole");
    let o = crate::kit::bin()
        .args([
            "run",
            survey.to_str().unwrap(),
            "-o",
            whole.to_str().unwrap(),
        ])
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .output()
        .unwrap();
    assert!(o.status.success());
    for f in ["points.las", "points.xyz", "survey.toml", "trajectory.csv"] {
        assert!(
            std::fs::read(whole.join(f)).unwrap() == std::fs::read(out.join(f)).unwrap(),
            "{f} differs"
        );
    }
    let never = std::fs::read_to_string(state.join("never")).unwrap_or_default();
    assert_eq!(never.is_empty(), !follow, "{never}");
    std::fs::remove_dir_all(&dir).ok();
    (log, never)
}
