//! ParaView data collections (`.pvd`): a list of datasets with their times, which ParaView
//! (File → Open) loads as one time series. Datasets that share a time are told apart by `part`
//! (ParaView shows them as blocks of one dataset); `name` labels each.

use std::fmt::Write;

use super::data_array::{escape, vtk_file_open};

/// One dataset of a collection.
#[derive(Clone, Debug, PartialEq)]
pub struct PvdEntry {
    /// Time of the dataset (s).
    pub time_s: f64,
    /// Path of the dataset relative to the `.pvd` file ('/' separated).
    pub file: String,
    /// Label shown by ParaView.
    pub name: String,
}

/// The `.pvd` text listing `entries` in time order (stable for equal times).
pub fn collection(entries: &[PvdEntry]) -> String {
    let mut sorted: Vec<&PvdEntry> = entries.iter().collect();
    sorted.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let mut o = vtk_file_open("Collection");
    o.push_str("  <Collection>\n");
    let mut part = 0;
    for (k, e) in sorted.iter().enumerate() {
        part = if k > 0 && sorted[k - 1].time_s == e.time_s {
            part + 1
        } else {
            0
        };
        writeln!(
            o,
            "    <DataSet timestep=\"{:e}\" group=\"\" part=\"{part}\" name=\"{}\" file=\"{}\"/>",
            e.time_s,
            escape(&e.name),
            escape(&e.file)
        )
        .expect("string");
    }
    o.push_str("  </Collection>\n</VTKFile>\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_are_sorted_and_equal_times_get_parts() {
        let e = |t: f64, f: &str| PvdEntry {
            time_s: t,
            file: f.into(),
            name: f.into(),
        };
        let s = collection(&[e(0.5, "b.vti"), e(0.25, "a.vti"), e(0.5, "c&d.vti")]);
        let a = s.find("a.vti").unwrap();
        let b = s.find("b.vti").unwrap();
        assert!(a < b);
        assert!(
            s.contains("timestep=\"5e-1\" group=\"\" part=\"1\" name=\"c&amp;d.vti\""),
            "{s}"
        );
    }
}
