//! Standard output without panics.
//!
//! `println!` panics when the write fails ("failed printing to stdout"), and
//! Rust ignores SIGPIPE, so `km solve ... | head -c 10` used to end in a panic
//! (exit 101), `> /dev/full` too, and a closed standard output was silently
//! taken as success. Here:
//!
//! * [`init`] (first thing in `main`) restores the default action of SIGPIPE,
//!   so a reader that goes away ends km quietly, as it ends `cat` or `seq`
//!   (the shell reports status 141 = 128 + SIGPIPE);
//! * [`print`] writes and flushes, and turns every other failure (a full
//!   disk, a closed or read-only standard output) into an error for `main`
//!   to report with a non-zero exit status.
//!
//! Every print of the CLI goes through [`print`] (or [`print_json`]), and
//! every message on standard error through [`eprint`] (or [`report_error`]):
//! `eprintln!` panics on a full or closed standard error (exit 101).

use std::io::Write;

use anyhow::{Result, anyhow};

/// Exit status of a process ended by SIGPIPE, as shells report it.
pub const BROKEN_PIPE_STATUS: i32 = 128 + libc::SIGPIPE;

/// Restore the default action of SIGPIPE (the Rust runtime ignores it).
pub fn init() {
    // SAFETY: setting a signal's disposition to its default is always sound.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Whether file descriptor 1 is open for writing.
///
/// Rust's standard output reports success on a closed descriptor (EBADF),
/// and before `main` the Rust runtime reopens a closed descriptor 0, 1 or 2
/// on `/dev/null` *read-write*: a standard output that is `/dev/null` opened
/// read-write is therefore taken for a closed one (a shell's `> /dev/null`
/// opens it write-only and is accepted).
fn check_writable() -> Result<()> {
    // SAFETY: F_GETFL only reads the descriptor's flags.
    let flags = unsafe { libc::fcntl(1, libc::F_GETFL) };
    if flags == -1 {
        return Err(anyhow!("cannot write to standard output: it is closed"));
    }
    if flags & libc::O_ACCMODE == libc::O_RDONLY {
        return Err(anyhow!("cannot write to standard output: it is open for reading only"));
    }
    if flags & libc::O_ACCMODE == libc::O_RDWR && is_dev_null(1) {
        return Err(anyhow!(
            "cannot write to standard output: it is closed (the runtime put /dev/null in its place)"
        ));
    }
    Ok(())
}

/// Whether descriptor `fd` is the `/dev/null` device.
fn is_dev_null(fd: libc::c_int) -> bool {
    use std::os::unix::fs::MetadataExt;
    // SAFETY: fstat writes into a zeroed stat buffer of the right type.
    let mut st: libc::stat = unsafe { std::mem::zeroed() };
    if unsafe { libc::fstat(fd, &mut st) } != 0 {
        return false;
    }
    let is_chr = st.st_mode & libc::S_IFMT == libc::S_IFCHR;
    let null_rdev = std::fs::metadata("/dev/null").map(|m| m.rdev()).ok();
    is_chr && Some(st.st_rdev) == null_rdev
}

/// Write `text` to standard output and flush it.
///
/// # Errors
/// A closed or read-only standard output, or any write error (e.g. "No space
/// left on device" on `/dev/full`), as a message naming standard output. A
/// broken pipe never returns: the process ends quietly with
/// [`BROKEN_PIPE_STATUS`] (by the signal itself after [`init`]).
pub fn print(text: &str) -> Result<()> {
    check_writable()?;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            std::process::exit(BROKEN_PIPE_STATUS)
        }
        Err(e) => Err(anyhow!("cannot write to standard output: {e}")),
    }
}

/// [`print`] a JSON value, pretty, with a final newline.
pub fn print_json(value: &serde_json::Value) -> Result<()> {
    print(&format!("{}\n", serde_json::to_string_pretty(value)?))
}

/// Write `text` to standard error and flush it.
///
/// # Errors
/// Any write error (e.g. `2> /dev/full`), as a message naming standard
/// error (which `main` then cannot print: it exits with status 2).
pub fn eprint(text: &str) -> Result<()> {
    let mut err = std::io::stderr().lock();
    err.write_all(text.as_bytes())
        .and_then(|()| err.flush())
        .map_err(|e| anyhow!("cannot write to standard error: {e}"))
}

/// Print `error: MESSAGE` on standard error, ignoring a failure to write
/// (there is nowhere left to report it; the exit status says it).
pub fn report_error(e: &anyhow::Error) {
    let _ = eprint(&format!("error: {e:#}\n"));
}
