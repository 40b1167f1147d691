//! The table of `docs/robot-integration.md` that says which readings each flag doubts is
//! `Flag::concerns`, row by row.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_protocol::{Flag, Reading};

#[test]
fn the_documented_table_is_what_flags_concern() {
    let doc = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/robot-integration.md"),
    )
    .unwrap();
    let header = doc
        .lines()
        .find(|l| l.starts_with("| flag |"))
        .expect("the table's header");
    let columns: Vec<&str> = header.split('|').map(str::trim).skip(2).collect();
    let names: Vec<&str> = Reading::ALL.iter().map(|r| r.name()).collect();
    assert_eq!(&columns[..names.len()], names.as_slice(), "{header}");
    let mut rows = 0;
    for line in doc.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let Some(flag) = Flag::from_name(cells[1].trim_matches('`')) else {
            continue;
        };
        for (r, cell) in Reading::ALL.into_iter().zip(&cells[2..]) {
            assert_eq!(
                flag.concerns(r),
                *cell == "✓",
                "{} {}: {line}",
                flag.name(),
                r.name()
            );
        }
        rows += 1;
    }
    assert_eq!(rows, Flag::ALL.len(), "one row per flag");
}
