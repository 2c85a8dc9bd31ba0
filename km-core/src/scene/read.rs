//! Reading a scene file's text under its size limit, and the line of a byte
//! offset for the errors.

use std::io::Read;
use std::ops::Range;
use std::path::Path;

use crate::error::CoreError;

/// Byte offsets of the line starts of a text, built in one pass, so that the
/// line of a byte offset is a binary search (the parser asks for one line per
/// value: a scan from the start for each was quadratic in the file size).
pub(super) struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    pub(super) fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.bytes().enumerate().filter(|&(_, b)| b == b'\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    /// 1-based line of byte offset `at` (offsets past the end give the last line).
    pub(super) fn line(&self, at: usize) -> usize {
        // Number of line starts at or before `at`.
        self.starts.partition_point(|&s| s <= at)
    }
}

fn line_of(text: &str, span: Range<usize>) -> usize {
    LineIndex::new(text).line(span.start.min(text.len()))
}

pub(super) fn too_big(what: &str, bytes: u64, max: u64) -> CoreError {
    too_big_for(what, bytes, max, "KM_MAX_SCENE_BYTES")
}

fn too_big_for(what: &str, bytes: u64, max: u64, env: &str) -> CoreError {
    let raise = if env.is_empty() { String::new() } else { format!("set {env} to raise it; ") };
    CoreError::scene(
        "file",
        None,
        format!("{what} of {bytes} bytes is over the limit of {max} bytes ({raise}docs/limits.md)"),
    )
}

/// The text of a scene file read as [`Scene::from_path`] reads it: at most
/// `max` bytes; `-` is standard input; anything else must be a regular file
/// (checked before opening, so a FIFO without a writer or `/dev/zero` is
/// refused at once), opened without blocking.
///
/// # Errors
/// Those of [`Scene::from_path`] about the file.
pub fn read_scene_text(path: &Path, max: u64) -> Result<String, CoreError> {
    read_checked_text(path, max, "a scene", "KM_MAX_SCENE_BYTES")
}

/// The text of any input file (a scene, a measurement file), checked as
/// [`read_scene_text`] checks a scene: at most `max` bytes (`env` names the
/// variable that raises the limit in the message, if any: may be empty); `-` is standard input;
/// anything else must be a regular file, checked before opening and opened
/// without blocking; `what` names the file's role in the messages ("a
/// measurement file").
///
/// # Errors
/// A file that is missing, not a regular file, over `max` bytes or not UTF-8.
pub fn read_checked_text(
    path: &Path,
    max: u64,
    what: &str,
    env: &str,
) -> Result<String, CoreError> {
    let shown = path.display();
    let too_big = |w: &str, b: u64| too_big_for(w, b, max, env);
    let io =
        |e: std::io::Error| CoreError::scene("file", None, format!("cannot read {shown}: {e}"));
    let not_regular = |m: &std::fs::Metadata| {
        CoreError::scene(
            "file",
            None,
            format!(
                "{shown} is {}: {what} must be a regular file (or - for standard input)",
                crate::atomic_file::kind(&m.file_type())
            ),
        )
    };
    let mut buf = Vec::new();
    if path.as_os_str() == "-" {
        std::io::stdin().lock().take(max + 1).read_to_end(&mut buf).map_err(io)?;
        if buf.len() as u64 > max {
            return Err(too_big("standard input", buf.len() as u64));
        }
    } else {
        // The type before opening: opening a FIFO with no writer blocks.
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(not_regular(&meta));
        }
        if meta.len() > max {
            return Err(too_big(&format!("{shown}"), meta.len()));
        }
        // O_NONBLOCK: should the path be swapped for a FIFO after the check,
        // the open does not hang.
        use std::os::unix::fs::OpenOptionsExt;
        let f = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(path)
            .map_err(io)?;
        let meta = f.metadata().map_err(io)?;
        if !meta.is_file() {
            return Err(not_regular(&meta));
        }
        // A file that grows while read is cut at max + 1 bytes and refused.
        f.take(max + 1).read_to_end(&mut buf).map_err(io)?;
        if buf.len() as u64 > max {
            return Err(too_big(&format!("{shown}"), buf.len() as u64));
        }
    }
    String::from_utf8(buf).map_err(|e| {
        CoreError::scene(
            "file",
            None,
            format!(
                "{shown} is not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

pub(super) fn toml_error(text: &str, e: &toml::de::Error) -> CoreError {
    let line = e.span().map(|s| line_of(text, s));
    // toml's message names the key (e.g. "unknown field `sigmaa`, expected ...").
    let msg = internal_names(e.message().trim());
    let key = msg
        .split('`')
        .nth(1)
        .filter(|_| msg.contains("unknown field") || msg.contains("missing field"))
        .unwrap_or("scene")
        .to_string();
    CoreError::scene(key, line, msg)
}

/// A parser message with the parser's own type names in words: "expected
/// struct RawLight" says "expected a table (struct RawLight is internal)".
fn internal_names(msg: &str) -> String {
    let mut out = String::new();
    let mut rest = msg;
    while let Some(i) = rest.find("struct Raw") {
        out.push_str(&rest[..i]);
        let tail = &rest[i + "struct Raw".len()..];
        let end = tail.find(|c: char| !c.is_alphanumeric()).unwrap_or(tail.len());
        out.push_str("a table");
        rest = &tail[end..];
    }
    out.push_str(rest);
    out
}
