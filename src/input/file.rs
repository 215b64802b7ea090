//! Reading a study or scene file: text of bounded size, so that a path such as
//! `/dev/zero` or a mistaken multi-gigabyte file is refused instead of filling memory.

use std::io::Read;
use std::path::Path;

/// No study or scene comes near this; the largest bundled one is a few kilobytes.
pub const MAX_BYTES: u64 = 16 << 20;

/// The file's text, or why it cannot be had (unreadable, too large, not UTF-8).
pub fn read(path: &Path) -> Result<String, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let bytes = read_at_most(file, MAX_BYTES, "not a study or scene file")?;
    String::from_utf8(bytes).map_err(|_| "not UTF-8 text".to_string())
}

/// At most `max` bytes of `file`, never more read; beyond, an error naming the bound and
/// `what` the file then cannot be.
pub fn read_at_most(file: std::fs::File, max: u64, what: &str) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    file.take(max + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > max {
        return Err(format!("larger than {} MiB: {what}", max >> 20));
    }
    Ok(bytes)
}
