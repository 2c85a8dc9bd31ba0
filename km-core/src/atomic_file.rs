//! Safe output files: written whole or not at all, never over something that
//! is not a plain file, never over an input.
//!
//! [`write_atomic`] writes into a temporary file created next to the target
//! with `O_CREAT | O_EXCL | O_NOFOLLOW` under a random name (a planted file or
//! symbolic link at that name makes the creation fail instead of being
//! followed), flushes it to disk, and renames it over the target: POSIX
//! `rename(2)` is atomic, so a reader sees the old file or the new one, never
//! a truncated one. Before writing, the target is checked:
//!
//! * it must be absent or a regular file: a directory, FIFO, socket or device
//!   node is refused (renaming over `/dev/null` would replace the device);
//! * a symbolic link is refused unless [`WriteOptions::follow_symlinks`] is
//!   set, in which case the file it points to is written;
//! * it must not be one of [`WriteOptions::inputs`] (compared by device and
//!   inode, and by canonical path), so `km solve s.toml --out s.toml` cannot
//!   overwrite its own scene.
//!
//! The temporary file is removed on every error and, through a small registry
//! of live temporary files and a handler of SIGINT, SIGTERM and SIGHUP, when
//! the process is interrupted while writing (the handler unlinks the
//! registered files, restores the default action and raises the signal again,
//! so the exit status stays the conventional one). The checks and the rename
//! are not one atomic step: a target swapped between them by another process
//! with write access to the directory is not detected.
//!
//! Unix only (the workspace targets Linux).

use std::collections::hash_map::RandomState;
use std::ffi::CString;
use std::fs::{File, OpenOptions};
use std::hash::BuildHasher;
use std::io::{Error, ErrorKind, Write};
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::sync::Once;
use std::sync::atomic::{AtomicBool, AtomicPtr, Ordering};

/// What [`write_atomic_with`] may do.
#[derive(Debug, Clone, Default)]
pub struct WriteOptions {
    /// Files that must not be overwritten (the inputs of the computation).
    pub inputs: Vec<PathBuf>,
    /// Write through a symbolic link at the target (default: refuse it).
    pub follow_symlinks: bool,
}

/// Write `bytes` to `path` atomically with the default [`WriteOptions`]
/// (no inputs to protect, symbolic links refused).
///
/// # Errors
/// See [`write_atomic_with`].
///
/// ```
/// let dir = std::env::temp_dir().join(format!("km-doc-atomic-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let p = dir.join("a.json");
/// km_core::atomic_file::write_atomic(&p, b"{}").unwrap();
/// assert_eq!(std::fs::read(&p).unwrap(), b"{}");
/// // A directory is not a file to replace.
/// assert!(km_core::atomic_file::write_atomic(&dir, b"{}").is_err());
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, bytes, &WriteOptions::default())
}

/// Write `bytes` to `path` atomically (module documentation): checks the
/// target, writes a temporary file beside it, syncs, renames.
///
/// # Errors
/// `InvalidInput` when the target is a directory, device, FIFO, socket, a
/// symbolic link (unless followed) or one of `opts.inputs`; the I/O error of
/// creating, writing, syncing or renaming otherwise (the temporary file is
/// removed). Every message names the path.
pub fn write_atomic_with(path: &Path, bytes: &[u8], opts: &WriteOptions) -> std::io::Result<()> {
    let target = check_target(path, opts)?;
    let dir = target.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let (tmp, mut file) = create_temp(dir, &name)?;
    let guard = TempGuard::register(&tmp);
    let written = (|| {
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, &target)
    })();
    match written {
        Ok(()) => {
            guard.release();
            // Make the rename durable; a failure here loses nothing already visible.
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            guard.release();
            Err(Error::new(e.kind(), format!("writing {}: {e}", target.display())))
        }
    }
}

fn refuse(path: &Path, why: impl std::fmt::Display) -> Error {
    Error::new(ErrorKind::InvalidInput, format!("refusing to write {}: {why}", path.display()))
}

/// What a file system object is, in words (for refusals of writes and reads).
pub(crate) fn kind(ft: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if ft.is_dir() {
        "a directory"
    } else if ft.is_fifo() {
        "a FIFO (named pipe)"
    } else if ft.is_char_device() {
        "a character device"
    } else if ft.is_block_device() {
        "a block device"
    } else if ft.is_socket() {
        "a socket"
    } else if ft.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

/// The path to write (the link's target when following), after the checks.
fn check_target(path: &Path, opts: &WriteOptions) -> std::io::Result<PathBuf> {
    if path.as_os_str().is_empty() {
        return Err(refuse(path, "the path is empty"));
    }
    let mut target = path.to_path_buf();
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => Some(m),
        Err(e) if e.kind() == ErrorKind::NotFound => None,
        Err(e) => return Err(Error::new(e.kind(), format!("{}: {e}", path.display()))),
    };
    let meta = match meta {
        Some(m) if m.file_type().is_symlink() => {
            if !opts.follow_symlinks {
                return Err(refuse(
                    path,
                    "it is a symbolic link (writing would replace the link, not its target)",
                ));
            }
            // Follow the whole chain; a dangling link names a file to create.
            target = match std::fs::canonicalize(path) {
                Ok(t) => t,
                Err(_) => resolve_dangling(path)?,
            };
            std::fs::metadata(&target).ok()
        }
        m => m,
    };
    if let Some(m) = meta.as_ref().filter(|m| !m.is_file()) {
        return Err(refuse(path, format!("it is {}, not a regular file", kind(&m.file_type()))));
    }
    // The inputs: same inode, or the same canonical path.
    let canon_target = canonical_new(&target);
    for input in &opts.inputs {
        let same_inode = match (&meta, std::fs::metadata(input)) {
            (Some(t), Ok(i)) => t.dev() == i.dev() && t.ino() == i.ino(),
            _ => false,
        };
        let same_path = canon_target.is_some()
            && canon_target == std::fs::canonicalize(input).ok().or_else(|| canonical_new(input));
        if same_inode || same_path {
            return Err(refuse(
                path,
                format!("it is the input file {} (choose another output path)", input.display()),
            ));
        }
    }
    Ok(target)
}

/// A symbolic link whose target does not exist yet: its target, read one level
/// at a time (at most 40 levels, as the kernel's `MAXSYMLINKS`).
fn resolve_dangling(path: &Path) -> std::io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::read_link(&p) {
            Ok(t) => {
                p = if t.is_absolute() { t } else { p.parent().unwrap_or(Path::new(".")).join(t) };
            }
            Err(_) => return Ok(p),
        }
    }
    Err(refuse(path, "too many levels of symbolic links"))
}

/// Canonical form of a path that may not exist yet: its canonical parent and its name.
fn canonical_new(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = std::fs::canonicalize(p) {
        return Some(c);
    }
    let parent = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    Some(std::fs::canonicalize(parent).ok()?.join(p.file_name()?))
}

/// Create `dir/.NAME.RANDOM.tmp` exclusively, without following a link at that name.
fn create_temp(dir: &Path, name: &str) -> std::io::Result<(PathBuf, File)> {
    let state = RandomState::new();
    let mut last = None;
    for attempt in 0u64..16 {
        // RandomState is seeded from the OS's random source once per process
        // and varied per call: the name cannot be guessed in advance.
        let r = state.hash_one((std::process::id(), attempt, std::time::SystemTime::now()));
        let tmp = dir.join(format!(".{name}.{r:016x}.tmp"));
        match OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o644)
            .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
            .open(&tmp)
        {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => {
                return Err(Error::new(
                    e.kind(),
                    format!("cannot create a temporary file in {}: {e}", dir.display()),
                ));
            }
        }
    }
    Err(last.unwrap_or_else(|| Error::other("no temporary name")))
}

// ---------------------------------------------------------------------------
// The registry of live temporary files, emptied by the signal handler.

/// Slots of registered temporary paths (NUL-terminated, owned by the registry).
const SLOTS: usize = 64;
static REGISTRY: [AtomicPtr<libc::c_char>; SLOTS] =
    [const { AtomicPtr::new(std::ptr::null_mut()) }; SLOTS];
/// Set by the handler before it reads a slot: a path released afterwards is
/// leaked instead of freed, so the handler never reads freed memory.
static IN_HANDLER: AtomicBool = AtomicBool::new(false);
static INSTALL: Once = Once::new();

/// Remove every registered file, then die of the same signal.
extern "C" fn on_signal(sig: libc::c_int) {
    IN_HANDLER.store(true, Ordering::SeqCst);
    for slot in &REGISTRY {
        let p = slot.load(Ordering::SeqCst);
        if !p.is_null() {
            // SAFETY: `p` is a NUL-terminated string owned by the registry and
            // not freed once IN_HANDLER is set; unlink is async-signal-safe.
            unsafe {
                libc::unlink(p);
            }
        }
    }
    // SAFETY: signal and raise are async-signal-safe.
    unsafe {
        libc::signal(sig, libc::SIG_DFL);
        libc::raise(sig);
    }
}

fn install_handlers() {
    INSTALL.call_once(|| {
        for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            // SAFETY: a plain handler that only calls async-signal-safe functions.
            unsafe {
                let old = libc::signal(sig, on_signal as *const () as libc::sighandler_t);
                // Keep an ignored signal ignored (e.g. SIGHUP under nohup).
                if old == libc::SIG_IGN {
                    libc::signal(sig, libc::SIG_IGN);
                }
            }
        }
    });
}

/// A registered temporary file; [`TempGuard::release`] unregisters it.
struct TempGuard {
    slot: Option<usize>,
}

impl TempGuard {
    fn register(path: &Path) -> TempGuard {
        install_handlers();
        let Ok(c) = CString::new(path.as_os_str().as_bytes()) else {
            return TempGuard { slot: None };
        };
        let raw = c.into_raw();
        for (i, slot) in REGISTRY.iter().enumerate() {
            if slot
                .compare_exchange(std::ptr::null_mut(), raw, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
            {
                return TempGuard { slot: Some(i) };
            }
        }
        // All slots busy (64 concurrent writes): the file is still removed on
        // errors, only not on signals.
        // SAFETY: `raw` came from CString::into_raw above and was not shared.
        drop(unsafe { CString::from_raw(raw) });
        TempGuard { slot: None }
    }

    fn release(mut self) {
        self.unregister();
    }

    fn unregister(&mut self) {
        if let Some(i) = self.slot.take() {
            let p = REGISTRY[i].swap(std::ptr::null_mut(), Ordering::SeqCst);
            if !p.is_null() && !IN_HANDLER.load(Ordering::SeqCst) {
                // SAFETY: `p` came from CString::into_raw in `register` and is
                // no longer reachable from the registry.
                drop(unsafe { CString::from_raw(p) });
            }
        }
    }
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        self.unregister();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tempdir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("km-atomic-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn leftovers(d: &Path) -> Vec<String> {
        std::fs::read_dir(d)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp"))
            .collect()
    }

    #[test]
    fn replaces_a_file_and_leaves_no_temporary() {
        let d = tempdir("replace");
        let p = d.join("out.json");
        write_atomic(&p, b"old").unwrap();
        write_atomic(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert!(leftovers(&d).is_empty());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn refuses_symlinks_unless_followed_and_devices_behind_them() {
        let d = tempdir("link");
        let real = d.join("real.json");
        std::fs::write(&real, b"keep").unwrap();
        let link = d.join("link.json");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        let e = write_atomic(&link, b"x").unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert_eq!(std::fs::read(&real).unwrap(), b"keep");
        // Followed: the link stays a link and its target gets the bytes.
        let opts = WriteOptions { follow_symlinks: true, ..Default::default() };
        write_atomic_with(&link, b"new", &opts).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        // A link to a device is refused even when followed.
        let dev = d.join("null");
        std::os::unix::fs::symlink("/dev/null", &dev).unwrap();
        let e = write_atomic_with(&dev, b"x", &opts).unwrap_err();
        assert!(e.to_string().contains("character device"), "{e}");
        assert!(leftovers(&d).is_empty());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn refuses_inputs_by_inode_and_by_path() {
        let d = tempdir("input");
        let scene = d.join("s.toml");
        std::fs::write(&scene, b"[[layer]]").unwrap();
        let opts = WriteOptions { inputs: vec![scene.clone()], ..Default::default() };
        let e = write_atomic_with(&scene, b"x", &opts).unwrap_err();
        assert!(e.to_string().contains("input file"), "{e}");
        // The same file by another name (a hard link).
        let hard = d.join("hard.toml");
        std::fs::hard_link(&scene, &hard).unwrap();
        assert!(write_atomic_with(&hard, b"x", &opts).is_err());
        // Through `dir/../dir/s.toml`.
        let roundabout = d.join("..").join(d.file_name().unwrap()).join("s.toml");
        assert!(write_atomic_with(&roundabout, b"x", &opts).is_err());
        assert_eq!(std::fs::read(&scene).unwrap(), b"[[layer]]");
        // Another file is fine.
        write_atomic_with(&d.join("out.json"), b"x", &opts).unwrap();
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn refuses_directories_and_missing_parents() {
        let d = tempdir("dir");
        assert!(write_atomic(&d, b"x").is_err());
        assert!(write_atomic(&d.join("no/such/dir/x"), b"x").is_err());
        assert!(write_atomic(Path::new(""), b"x").is_err());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_planted_file_at_a_temporary_name_is_not_followed() {
        // O_EXCL | O_NOFOLLOW: creation fails on an existing name, links included.
        let d = tempdir("plant");
        let victim = d.join("victim");
        std::fs::write(&victim, b"safe").unwrap();
        let planted = d.join(".x.tmp");
        std::os::unix::fs::symlink(&victim, &planted).unwrap();
        let r = OpenOptions::new()
            .write(true)
            .create_new(true)
            .custom_flags(libc::O_NOFOLLOW)
            .open(&planted);
        assert_eq!(r.unwrap_err().kind(), ErrorKind::AlreadyExists);
        assert_eq!(std::fs::read(&victim).unwrap(), b"safe");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
