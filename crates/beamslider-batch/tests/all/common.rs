//! Helpers shared by the integration tests of `beamslider-batch`.

use std::path::Path;
use std::process::Command;

/// The batch binary.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_beamslider-batch"))
}

/// Rows of a map results file: complete lines after the header, wall time removed, sorted by grid
/// index.
pub fn rows(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut v: Vec<(usize, String)> = text
        .split_inclusive('\n')
        .skip(1)
        .filter(|l| l.ends_with('\n'))
        .map(|l| {
            let l = l.trim_end();
            let cut = l.find(",\"wall_time_s\":").expect("wall time field");
            let idx: usize = l["{\"index\":".len()..l.find(',').unwrap()].parse().unwrap();
            (idx, l[..cut].to_string())
        })
        .collect();
    v.sort();
    v.into_iter().map(|(_, l)| l).collect()
}
