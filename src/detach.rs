//! The command's answer before the process's end (Linux): a `render` that may open a GL
//! context forks before anything else runs; the child does the work and, once every file
//! is written and its output flushed, sends its exit code to the parent, which exits with
//! it at once, while the child goes on to its own end: the release of the GPU driver's
//! state when a process exits, 60-80 ms on the H100 and H200 machines after `main` had
//! returned (and the same with `_exit` or without `eglTerminate`, docs/performance.md), no
//! longer held against the command. The linker mold does the same for its output file's
//! unmapping.
//!
//! What the caller sees is unchanged: the exit code is the child's (a child that dies
//! without answering passes on its own status, a signal as that signal); a signal that
//! ends the parent while the child works (Ctrl-C reaches both; `timeout` and a scheduler's
//! cancel reach the parent) ends the child too (`PR_SET_PDEATHSIG`, cleared once the answer
//! is due); standard output and error are the same streams (a pipe on them closes when the
//! child ends, so a reader of it still waits for the whole). `FRAGTRACE_DETACH_EXIT=0`
//! keeps the work in the one process.

/// Environment variable that keeps the work in one process when `0`.
pub const DETACH_ENV: &str = "FRAGTRACE_DETACH_EXIT";

/// Environment variable (tests only): milliseconds the child waits after answering, as a
/// slow driver release would, so that a test can see the answer come first.
pub const LINGER_ENV: &str = "FRAGTRACE_DETACH_TEST_LINGER_MS";

/// The child's end of the answer: [`Answer::send`] passes the exit code to the waiting
/// parent.
#[derive(Debug)]
pub struct Answer {
    #[cfg(target_os = "linux")]
    fd: std::os::fd::OwnedFd,
}

/// Whether [`split`] is wanted: not where [`DETACH_ENV`] is `0`.
pub fn wanted() -> bool {
    std::env::var(DETACH_ENV).map_or(true, |v| v != "0")
}

/// Forks: in the parent, waits for the child's answer and exits with it (never returns);
/// in the child, returns the answer to send. None where the platform or the system cannot
/// fork (the work then stays in this process). Call it before any thread is started.
#[cfg(target_os = "linux")]
pub fn split() -> Option<Answer> {
    use std::os::fd::{FromRawFd, OwnedFd};
    let mut fds = [0; 2];
    // SAFETY: pipe2 fills the two descriptors, owned at once below.
    if unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) } != 0 {
        return None;
    }
    // SAFETY: fresh descriptors of this process, each owned once.
    let (read, write) = unsafe { (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1])) };
    // SAFETY: getpid has no preconditions.
    let parent = unsafe { libc::getpid() };
    // SAFETY: called before any thread starts (the caller's contract), so the child's
    // copy of the process is whole.
    match unsafe { libc::fork() } {
        -1 => None,
        0 => {
            drop(read);
            // SAFETY: prctl with an integer argument; getppid has no preconditions.
            unsafe {
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM as libc::c_ulong);
                // The parent ended before the line above: end as it would have ended us.
                if libc::getppid() != parent {
                    libc::_exit(143);
                }
            }
            Some(Answer { fd: write })
        }
        child => {
            drop(write);
            wait_for_answer(read, child)
        }
    }
}

/// No fork off Linux: the work stays in this process.
#[cfg(not(target_os = "linux"))]
pub fn split() -> Option<Answer> {
    None
}

/// The parent's part: exits with the code the child sends, or, where the child ends
/// without one, with the child's own status.
#[cfg(target_os = "linux")]
fn wait_for_answer(read: std::os::fd::OwnedFd, child: libc::pid_t) -> ! {
    use std::os::fd::AsRawFd;
    let mut code = [0u8; 1];
    loop {
        // SAFETY: reads at most one byte into `code` from an open descriptor.
        let n = unsafe { libc::read(read.as_raw_fd(), code.as_mut_ptr().cast(), 1) };
        if n == 1 {
            // SAFETY: _exit ends this process without running anything more.
            unsafe { libc::_exit(i32::from(code[0])) }
        }
        if n == 0 || std::io::Error::last_os_error().kind() != std::io::ErrorKind::Interrupted {
            break;
        }
    }
    let mut status = 0;
    // SAFETY: waits for this process's own child; `status` is a valid out-pointer.
    unsafe {
        while libc::waitpid(child, &mut status, 0) == -1
            && std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted
        {}
        if libc::WIFEXITED(status) {
            libc::_exit(libc::WEXITSTATUS(status));
        }
        if libc::WIFSIGNALED(status) {
            let sig = libc::WTERMSIG(status);
            libc::signal(sig, libc::SIG_DFL);
            libc::raise(sig);
        }
        libc::_exit(1)
    }
}

/// The process's last step before its exit: sends `code` where a parent waits for it
/// ([`split`]), then waits what [`LINGER_ENV`] says (tests).
pub fn finish(answer: Option<Answer>, code: i32) {
    if let Some(answer) = answer {
        answer.send(code);
    }
    if let Some(ms) = std::env::var(LINGER_ENV).ok().and_then(|v| v.parse().ok()) {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
}

impl Answer {
    /// Sends `code` to the waiting parent, after flushing standard output (standard error
    /// is unbuffered), and stops the parent's end from ending this process.
    pub fn send(self, code: i32) {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        #[cfg(target_os = "linux")]
        {
            use std::os::fd::AsRawFd;
            let byte = [code.clamp(0, 255) as u8];
            // SAFETY: prctl with an integer argument; write of one byte from a live buffer
            // to an open descriptor (a parent already gone makes it fail with EPIPE:
            // Rust ignores SIGPIPE).
            unsafe {
                libc::prctl(libc::PR_SET_PDEATHSIG, 0 as libc::c_ulong);
                libc::write(self.fd.as_raw_fd(), byte.as_ptr().cast(), 1);
            }
        }

        #[cfg(not(target_os = "linux"))]
        let _ = code;
    }
}
