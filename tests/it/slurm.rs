//! The Slurm job scripts of `examples/slurm` on a real Slurm: a single-node cluster (munged,
//! slurmctld, slurmd) started on localhost by `examples/slurm/local-cluster.sh` for this
//! test and stopped after it. A job builds the tables once, a job array renders the tiles
//! reading them, and a dependent job merges the tiles; the result must be the local render
//! byte for byte. A second array renders frames.
//!
//! Needs Debian's `slurm-wlm` and `munge` (`bash .ci/setup` installs them) and root (the
//! daemons run as root); without them the test fails and says so.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{cuberay, shared};

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn script(name: &str) -> PathBuf {
    repo().join("examples/slurm").join(name)
}

/// A private cluster; stopped (and its folder removed) when dropped, also when the test fails.
struct Cluster {
    dir: tempfile::TempDir,
    conf: String,
}

impl Cluster {
    fn start() -> Cluster {
        let uid = Command::new("id").arg("-u").output().expect("id runs");
        assert!(
            String::from_utf8_lossy(&uid.stdout).trim() == "0",
            "the Slurm test starts munged, slurmctld and slurmd on localhost and must run as root"
        );
        for bin in ["munged", "slurmctld", "slurmd", "sbatch", "squeue"] {
            let found = Command::new("sh").arg("-c").arg(format!("command -v {bin}")).output().unwrap();
            assert!(
                found.status.success(),
                "{bin} is not installed: the Slurm test needs Debian's slurm-wlm and munge \
                 (`apt-get install slurm-wlm munge`, or `bash .ci/setup`)"
            );
        }
        // A path without spaces whose parents munged accepts (/tmp is sticky).
        let dir = tempfile::Builder::new().prefix("cuberay-slurm-").tempdir_in("/tmp").unwrap();
        let out = Command::new(script("local-cluster.sh"))
            .arg("start")
            .arg(dir.path().join("cluster"))
            .env("SLURM_LOCAL_CTLD_PORT", "16817")
            .env("SLURM_LOCAL_SLURMD_PORT", "16818")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "the local cluster did not start:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let stdout = String::from_utf8(out.stdout).unwrap();
        let conf = stdout
            .lines()
            .find_map(|l| l.strip_prefix("export SLURM_CONF="))
            .expect("start prints SLURM_CONF")
            .to_string();
        Cluster { dir, conf }
    }

    /// A command run against this cluster, with the cuberay binary under test.
    fn command(&self, program: &Path) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf).env("CUBERAY", env!("CARGO_BIN_EXE_cuberay"));
        c
    }

    /// Submits with submit.sh and returns the job ids it printed.
    fn submit(&self, args: &[&str]) -> Vec<String> {
        let out = self.command(&script("submit.sh")).args(args).output().unwrap();
        assert!(out.status.success(), "submit.sh {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap().split_whitespace().map(String::from).collect()
    }

    /// Waits for `jobs`; panics with the jobs' logs in `logs` unless every one completed.
    fn wait(&self, jobs: &[String], logs: &Path) {
        let out = self
            .command(&script("local-cluster.sh"))
            .arg("wait")
            .arg(self.dir.path().join("cluster"))
            .args(jobs)
            .env("SLURM_LOCAL_WAIT_TIMEOUT", "600")
            .output()
            .unwrap();
        if !out.status.success() {
            let mut text = String::from_utf8_lossy(&out.stderr).to_string();
            for e in std::fs::read_dir(logs).into_iter().flatten().flatten() {
                if e.path().extension().is_some_and(|x| x == "log") {
                    text += &format!(
                        "\n--- {} ---\n{}",
                        e.path().display(),
                        std::fs::read_to_string(e.path()).unwrap_or_default()
                    );
                }
            }
            panic!("Slurm jobs {jobs:?} did not all complete:\n{text}");
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(script("local-cluster.sh"))
            .arg("stop")
            .arg(self.dir.path().join("cluster"))
            .output();
    }
}

fn render_locally(args: &[&str]) {
    let out = cuberay().arg("render").args(args).output().unwrap();
    assert!(out.status.success(), "local render {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn a_slurm_job_array_renders_tiles_and_frames_as_one_machine_does() {
    let cluster = Cluster::start();
    let work = cluster.dir.path();
    let rings = shared("spd/nff/rings_s1.nff");
    let rings = rings.to_str().unwrap();
    let image = ["--width", "64", "--height", "48", "--sampling", "corners"];

    // Four tiles on the GPU backend, then the merge job.
    let merged = work.join("out/rings.exr");
    let mut args = vec!["--tiles", "4", rings, merged.to_str().unwrap()];
    args.extend_from_slice(&image);
    let jobs = cluster.submit(&args);
    assert_eq!(jobs.len(), 3, "submit.sh prints the tables', the array's and the merge's job ids: {jobs:?}");
    let parts = work.join("out/rings.exr.parts");
    cluster.wait(&jobs, &parts);
    // EXR: the f32 values as rendered, so equal files mean equal pixels to the last bit.
    let local = work.join("local.exr");
    let mut args = vec![rings, "-o", local.to_str().unwrap()];
    args.extend_from_slice(&image);
    render_locally(&args);
    assert!(
        std::fs::read(&merged).unwrap() == std::fs::read(&local).unwrap(),
        "the image merged on Slurm differs from the local render"
    );
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(parts.join("merged.json")).unwrap()).unwrap();
    assert_eq!(stats["rays"]["eye"], 65 * 49, "every corner ray counted once");
    let tiles = std::fs::read_dir(&parts)
        .unwrap()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "exr"))
        .count();
    assert_eq!(tiles, 4);
    assert!(parts.join("scene.tables").is_file(), "the tables job wrote the shared tables");

    // An animation: one array task per frame, on the CPU backend.
    let orbit = repo().join("scenes/orbit.gltf");
    let frames = work.join("frames/orbit_##.png");
    let small = ["--backend", "cpu", "--width", "40", "--height", "30", "--fps", "1"];
    let mut args = vec!["--frames", "0..2", orbit.to_str().unwrap(), frames.to_str().unwrap()];
    args.extend_from_slice(&small);
    let jobs = cluster.submit(&args);
    cluster.wait(&jobs, &work.join("frames"));
    let local = work.join("local_##.png");
    let mut args = vec![orbit.to_str().unwrap(), "--frames", "0..2", "-o", local.to_str().unwrap()];
    args.extend_from_slice(&small);
    render_locally(&args);
    for f in 0..3 {
        let (rendered, local) =
            (work.join(format!("frames/orbit_{f:02}.png")), work.join(format!("local_{f:02}.png")));
        assert!(
            std::fs::read(&rendered).unwrap() == std::fs::read(&local).unwrap(),
            "frame {f} rendered on Slurm differs from the local render"
        );
    }
}
