//! JSON-lines results files of records of any shape (design runs, docs/model.md §8): a header on
//! line 1 naming the format and its version, one record a line, a torn last line (a writer killed
//! mid-line) ignored on reading and cut off before appending, each line flushed and synced.
//! Maps and studies read their rows as [`super::MapRow`]s ([`super::read_results`]); all share
//! the one-writer lock ([`super::ResultsLock`]).

use std::fs::OpenOptions;
use std::io::Write;
use std::path::Path;

use super::file::io_err;
use crate::error::{Error, Result};

/// The complete lines of a JSON-lines file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JsonLines {
    /// The complete lines, header first (none for an empty file), without their newlines.
    pub lines: Vec<String>,
    /// Byte length of the complete part (a torn last line starts here).
    pub good_len: u64,
    /// Whether the file ended in an incomplete line.
    pub truncated: bool,
}

/// Read a JSON-lines file whose header (line 1) is an object with `key` = `version`. Every
/// complete line must be JSON; a damaged line or a header of another format is an error naming
/// the file and the line; an incomplete last line is reported as `truncated` and left out.
pub fn read_json_lines(path: &Path, key: &str, version: u64) -> Result<JsonLines> {
    read_tagged_lines(path, key, &serde_json::json!(version))
}

/// [`read_json_lines`] of a format whose header holds `tag` under `key` (a version number, or a
/// format's name as the drift tables of docs/model.md §6.3 have).
pub fn read_tagged_lines(path: &Path, key: &str, tag: &serde_json::Value) -> Result<JsonLines> {
    let data = std::fs::read(path).map_err(|e| io_err(path, e))?;
    let good = data.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let text = std::str::from_utf8(&data[..good])
        .map_err(|e| Error::invalid("results file", path.display(), &format!("not UTF-8 text (byte {})", e.valid_up_to())))?;
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    for (k, line) in lines.iter().enumerate() {
        let v: serde_json::Value = serde_json::from_str(line)
            .map_err(|_| Error::invalid("results file", format!("{}:{}", path.display(), k + 1), "this line is damaged (not JSON)"))?;
        if k == 0 && v.get(key) != Some(tag) {
            return Err(Error::invalid(
                "results file",
                path.display(),
                &format!("not a beamslider results file of this kind (line 1 without \"{key}\": {tag})"),
            ));
        }
    }
    Ok(JsonLines { lines, good_len: good as u64, truncated: good < data.len() })
}

/// Append `lines` to a JSON-lines file (created if missing), after cutting it to `good_len` when
/// given (a torn last line from a killed writer; the caller holds the lock). Each line is written
/// in one call, flushed and synced to the disk.
pub fn append_json_lines(path: &Path, good_len: Option<u64>, lines: &[String]) -> Result<()> {
    let mut f = OpenOptions::new().append(true).create(true).open(path).map_err(|e| io_err(path, e))?;
    if let Some(n) = good_len {
        f.set_len(n).map_err(|e| io_err(path, e))?;
    }
    for line in lines {
        f.write_all(format!("{line}\n").as_bytes()).map_err(|e| io_err(path, e))?;
        f.flush().and_then(|()| f.sync_data()).map_err(|e| io_err(path, e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn torn_last_line_is_left_out_then_cut_before_appending() {
        let dir = std::env::temp_dir().join(format!("beamslider_lines_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("d.jsonl");
        std::fs::write(&p, "{\"kind_x\": 1}\n{\"a\": 1}\n{\"a\": 2").unwrap();
        let r = read_json_lines(&p, "kind_x", 1).unwrap();
        assert_eq!(r.lines, vec!["{\"kind_x\": 1}", "{\"a\": 1}"]);
        assert!(r.truncated);
        append_json_lines(&p, Some(r.good_len), &["{\"a\": 3}".to_string()]).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "{\"kind_x\": 1}\n{\"a\": 1}\n{\"a\": 3}\n");
        assert!(read_json_lines(&p, "kind_x", 2).is_err());
        std::fs::write(&p, "{\"kind_x\": 1}\n{\"a\": \n{\"a\": 2}\n").unwrap();
        assert!(read_json_lines(&p, "kind_x", 1).unwrap_err().to_string().contains("d.jsonl:2"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
