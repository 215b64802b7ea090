//! Reading a study or scene file: text of bounded size, so that a path such as
//! `/dev/zero` or a mistaken multi-gigabyte file is refused instead of filling memory.

use std::io::Read;
use std::path::Path;

/// No study or scene comes near this; the largest bundled one is a few kilobytes.
pub const MAX_BYTES: u64 = 16 << 20;

/// The file's text, or why it cannot be had (unreadable, too large, not UTF-8).
pub fn read(path: &Path) -> Result<String, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut bytes = Vec::new();
    file.take(MAX_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > MAX_BYTES {
        return Err(format!(
            "larger than {} MiB: not a study or scene file",
            MAX_BYTES >> 20
        ));
    }
    String::from_utf8(bytes).map_err(|_| "not UTF-8 text".to_string())
}
