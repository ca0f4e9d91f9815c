//! The kit the command-line tests share: the binary, a fresh temporary
//! directory, a good survey and a run of a survey text.

// Each test file uses some of these.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The `lidarsim` binary.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lidarsim"))
}

/// An empty directory for test `name` of the calling file, named after
/// the file and the process so that tests of different files never share
/// one.
#[track_caller]
pub fn temp(name: &str) -> PathBuf {
    let file = Path::new(std::panic::Location::caller().file());
    let stem = file
        .file_stem()
        .map_or("test".into(), |s| s.to_string_lossy());
    let d = std::env::temp_dir().join(format!("lidarsim-cli-{stem}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A short survey over a plane that runs in a moment.
pub const GOOD: &str = r#"seed = 3

[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15

[[flight_line]]
start_m = [0.0, -10.0, 300.0]
end_m = [0.0, 10.0, 300.0]
speed_mps = 50.0

[output]
formats = ["las", "xyz"]

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

/// Writes `text` as `dir/survey.toml` and runs it into `dir/out`.
pub fn run_survey(dir: &Path, text: &str) -> (Output, PathBuf) {
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, text).unwrap();
    let out = dir.join("out");
    let o = bin()
        .arg("run")
        .arg(&survey)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    (o, out)
}

/// Address space allowed to a command run by [`limited`], bytes.
pub const ADDRESS_SPACE: u64 = 4 << 30;
/// Time allowed to a command run by [`limited`].
pub const TIMEOUT: Duration = Duration::from_secs(120);

/// A resource limit of a command run by [`limited_by`].
#[derive(Clone, Copy, Debug)]
pub enum Limit {
    /// Address space, bytes (`RLIMIT_AS`): a huge allocation fails
    /// instead of swapping the machine.
    AddressSpace(u64),
    /// Size of any file written, bytes (`RLIMIT_FSIZE`, with `SIGXFSZ`
    /// ignored so that a write past it fails): a full disk.
    FileSize(u64),
}

/// Runs `lidarsim ARGS` under [`ADDRESS_SPACE`] and [`TIMEOUT`], so that a
/// regression that allocates without bound or never ends fails the test
/// instead of exhausting the machine or hanging CI.
pub fn limited(args: &[&OsStr]) -> Output {
    limited_by(args, Limit::AddressSpace(ADDRESS_SPACE))
}

/// Runs `lidarsim ARGS` under `limit` (on Linux) and [`TIMEOUT`].
pub fn limited_by(args: &[&OsStr], limit: Limit) -> Output {
    let mut c = bin();
    c.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        let (resource, bytes) = match limit {
            Limit::AddressSpace(b) => (libc::RLIMIT_AS, b),
            Limit::FileSize(b) => (libc::RLIMIT_FSIZE, b),
        };
        // SAFETY: between fork and exec, only async-signal-safe calls
        // (setrlimit, signal) on plain values.
        unsafe {
            c.pre_exec(move || {
                let lim = libc::rlimit {
                    rlim_cur: bytes,
                    rlim_max: bytes,
                };
                if libc::setrlimit(resource, &lim) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                if matches!(limit, Limit::FileSize(_)) {
                    libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
                }
                Ok(())
            });
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = limit;
    let mut child = c.spawn().unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > TIMEOUT {
            child.kill().ok();
            let o = child.wait_with_output().unwrap();
            let shown: Vec<String> = args
                .iter()
                .map(|a| a.to_string_lossy().into_owned())
                .collect();
            panic!(
                "lidarsim {shown:?} still ran after {TIMEOUT:?}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Every file under `dir` (links not followed) with its bytes: what a test
/// compares before and after a command that must not touch them.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            let t = e.file_type().unwrap();
            if t.is_dir() {
                todo.push(e.path());
            } else if t.is_file() {
                out.insert(e.path(), std::fs::read(e.path()).unwrap());
            }
        }
    }
    out
}

/// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320), bit by bit as
/// the textbook defines it: the test's own check of the checksums parts
/// record, independent of the crate the program uses.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// Writes a LAS 1.2 file of points (x, y, z) with 1 cm precision.
pub fn write_las(path: &Path, points: &[(f64, f64, f64)]) {
    let points: Vec<las::Point> = points
        .iter()
        .map(|&(x, y, z)| las::Point {
            x,
            y,
            z,
            ..Default::default()
        })
        .collect();
    write_las_points(path, 0, &points);
}

/// Writes `points` as a LAS 1.2 file of point format `format` (0–3) with
/// 1 cm precision.
pub fn write_las_points(path: &Path, format: u8, points: &[las::Point]) {
    let mut builder = las::Builder::from((1, 2));
    builder.point_format = las::point::Format::new(format).unwrap();
    let centimetres = las::Transform {
        scale: 0.01,
        offset: 0.0,
    };
    builder.transforms = las::Vector {
        x: centimetres,
        y: centimetres,
        z: centimetres,
    };
    let mut w = las::Writer::from_path(path, builder.into_header().unwrap()).unwrap();
    for p in points {
        w.write_point(p.clone()).unwrap();
    }
    w.close().unwrap();
}
