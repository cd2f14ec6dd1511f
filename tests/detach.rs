//! `render` answers before its process's end (src/detach.rs): the command's process exits
//! with the worker's code once the files are written, while the worker goes on to the GPU
//! driver's release. A worker that lingers after answering (as a slow release would:
//! `FRAGTRACE_DETACH_TEST_LINGER_MS`) does not hold the command, which still exits with
//! the worker's code and leaves the whole image; `FRAGTRACE_DETACH_EXIT=0` keeps the work
//! in one process (the linger is then the command's). A signal that ends the command ends
//! its worker, which leaves no partial file; a worker killed before it answers makes the
//! command end by the same signal.

#![cfg(target_os = "linux")]

mod common;

use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// `render` of the built-in scene at `size`² on the GPU into `out` in `d`, its streams
/// discarded (a pipe on them would be held by the worker until its end).
fn spawn(d: &Path, size: &str, out: &str, env: &[(&str, &str)]) -> Child {
    common::bin()
        .current_dir(d)
        .args([
            "render",
            "--backend",
            "gl",
            "--width",
            size,
            "--height",
            size,
        ])
        .args(["-q", "-o", out])
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// The processes whose parent is `pid` (from /proc).
fn children(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(p) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{p}/stat")) else {
            continue;
        };
        // pid (comm) state ppid ...: the name may hold spaces, not ')'.
        let after = &stat[stat.rfind(')').unwrap() + 2..];
        let ppid: u32 = after.split(' ').nth(1).unwrap().parse().unwrap();
        if ppid == pid {
            out.push(p);
        }
    }
    out
}

fn alive(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .is_ok_and(|s| !s[s.rfind(')').unwrap() + 2..].starts_with('Z'))
}

/// The worker of command `c`, waited for up to 10 s.
fn worker_of(c: &Child) -> u32 {
    let t = Instant::now();
    loop {
        if let [w] = children(c.id())[..] {
            return w;
        }
        assert!(t.elapsed() < Duration::from_secs(10), "no worker process");
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn kill(sig: &str, pid: u32) {
    let s = Command::new("kill")
        .args([sig, &pid.to_string()])
        .status()
        .unwrap();
    assert!(s.success());
}

#[test]
fn the_command_answers_before_its_worker_ends() {
    let d = common::tmpdir("detach-answer");
    let linger = [("FRAGTRACE_DETACH_TEST_LINGER_MS", "3000")];
    let t = Instant::now();
    let mut c = spawn(&d, "48", "a.png", &linger);
    let w = worker_of(&c);
    let status = c.wait().unwrap();
    let took = t.elapsed();
    assert!(status.success(), "{status:?}");
    assert!(
        took < Duration::from_millis(2500),
        "the command took {took:?}: it waited for its worker's linger"
    );
    assert!(alive(w), "the worker ended with the command");
    let img = image::open(d.join("a.png")).unwrap();
    assert_eq!((img.width(), img.height()), (48, 48));
    // In one process, the linger is the command's.
    let t = Instant::now();
    let s = spawn(
        &d,
        "48",
        "b.png",
        &[linger[0], ("FRAGTRACE_DETACH_EXIT", "0")],
    )
    .wait()
    .unwrap();
    assert!(s.success());
    assert!(t.elapsed() >= Duration::from_millis(3000));
    assert!(std::fs::read(d.join("a.png")).unwrap() == std::fs::read(d.join("b.png")).unwrap());
    // The worker's error code is the command's.
    let s = common::bin()
        .current_dir(&d)
        .args([
            "render",
            "nosuch.toml",
            "--backend",
            "gl",
            "-q",
            "-o",
            "c.png",
        ])
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert_eq!(s.code(), Some(2));
}

#[test]
fn a_signal_to_the_command_ends_its_worker_without_a_partial_file() {
    let d = common::tmpdir("detach-signal");
    // Long enough on llvmpipe to be stopped while it renders.
    let mut c = spawn(&d, "1500", "big.png", &[]);
    let w = worker_of(&c);
    std::thread::sleep(Duration::from_millis(200));
    kill("-TERM", c.id());
    let status = c.wait().unwrap();
    assert_eq!(status.signal(), Some(15), "{status:?}");
    let t = Instant::now();
    while alive(w) {
        assert!(
            t.elapsed() < Duration::from_secs(10),
            "the worker outlived its command by 10 s"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let left: Vec<_> = std::fs::read_dir(&d).unwrap().flatten().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn a_worker_killed_before_it_answers_ends_the_command_by_that_signal() {
    let d = common::tmpdir("detach-killed");
    let mut c = spawn(&d, "1500", "big.png", &[]);
    let w = worker_of(&c);
    std::thread::sleep(Duration::from_millis(200));
    kill("-KILL", w);
    let status = c.wait().unwrap();
    assert_eq!(status.signal(), Some(9), "{status:?}");
}
