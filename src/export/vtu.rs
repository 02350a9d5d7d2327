//! A particle frame as a VTK `UnstructuredGrid` (`.vtu`): one point and one vertex cell per
//! particle, every per-particle quantity a point array whose name carries its units. In
//! ParaView, "Glyph" with a sphere scaled by `radius [m]` (scale factor 2) draws the spheres;
//! spherocylinders use `axis [1]` for the glyph orientation and `half_length [m]` for l/2.
//!
//! Point arrays: `id` (UInt32), `velocity [m/s]`, `angular_velocity [rad/s]` (when the run
//! rotates), `radius [m]`, `fixed` (UInt8, 1 for the chute's rough base), and for
//! spherocylinders `orientation [1]` (quaternion x, y, z, w, body → lab), `axis [1]` (unit body z
//! in the lab frame) and `half_length [m]`. The frame's times go in `FieldData`:
//! `TimeValue` (the job's clock, as in the `.pvd`) and `sim_time [s]`, plus `chunk` and `step`.

use std::fmt::Write;

use super::data_array::{vtk_file_open, write_data_array, Encoding, Values};
use crate::observe::snapshots::Frame;

/// VTK cell type of a single point.
const VTK_VERTEX: u8 = 1;

/// The `.vtu` text of `frame`.
pub fn frame_to_vtu(frame: &Frame, encoding: Encoding) -> String {
    let n = frame.len();
    let mut o = vtk_file_open("UnstructuredGrid");
    o.push_str("  <UnstructuredGrid>\n");
    o.push_str("    <FieldData>\n");
    let field = "      ";
    let data = |o: &mut String, name: &str, c: usize, v: Values<'_>| {
        write_data_array(o, field, name, c, v, encoding);
    };
    data(&mut o, "TimeValue", 1, Values::F64(&[frame.job_time_s]));
    data(&mut o, "sim_time [s]", 1, Values::F64(&[frame.sim_time_s]));
    data(&mut o, "chunk", 1, Values::I64(&[frame.chunk as i64]));
    data(&mut o, "step", 1, Values::I64(&[frame.step as i64]));
    o.push_str("    </FieldData>\n");
    writeln!(
        o,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">"
    )
    .expect("string");
    let point = "        ";
    let data = |o: &mut String, name: &str, c: usize, v: Values<'_>| {
        write_data_array(o, point, name, c, v, encoding);
    };
    o.push_str("      <PointData Scalars=\"radius [m]\" Vectors=\"velocity [m/s]\">\n");
    data(&mut o, "id", 1, Values::U32(&frame.id));
    data(
        &mut o,
        "velocity [m/s]",
        3,
        Values::F64(frame.vel.as_flattened()),
    );
    if !frame.omega.is_empty() {
        let w = frame.omega.as_flattened();
        data(&mut o, "angular_velocity [rad/s]", 3, Values::F64(w));
    }
    data(&mut o, "radius [m]", 1, Values::F64(&frame.radius));
    let fixed: Vec<u8> = frame.fixed.iter().map(|&f| u8::from(f)).collect();
    data(&mut o, "fixed", 1, Values::U8(&fixed));
    if frame.oriented() {
        let q = frame.orientation.as_flattened();
        data(&mut o, "orientation [1]", 4, Values::F64(q));
        let axes: Vec<[f64; 3]> = (0..n).map(|k| frame.axis(k)).collect();
        data(&mut o, "axis [1]", 3, Values::F64(axes.as_flattened()));
        data(
            &mut o,
            "half_length [m]",
            1,
            Values::F64(&frame.half_length),
        );
    }
    o.push_str("      </PointData>\n");
    o.push_str("      <Points>\n");
    data(
        &mut o,
        "position [m]",
        3,
        Values::F64(frame.pos.as_flattened()),
    );
    o.push_str("      </Points>\n");
    o.push_str("      <Cells>\n");
    let connectivity: Vec<i64> = (0..n as i64).collect();
    let offsets: Vec<i64> = (1..=n as i64).collect();
    data(&mut o, "connectivity", 1, Values::I64(&connectivity));
    data(&mut o, "offsets", 1, Values::I64(&offsets));
    data(&mut o, "types", 1, Values::U8(&vec![VTK_VERTEX; n]));
    o.push_str("      </Cells>\n");
    o.push_str("    </Piece>\n");
    o.push_str("  </UnstructuredGrid>\n</VTKFile>\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sphere_frame_has_no_orientation_arrays() {
        let f = Frame {
            job_hash: "h".into(),
            chunk: 2,
            step: 20,
            sim_time_s: 1.0,
            job_time_s: 0.1,
            id: vec![5],
            pos: vec![[1.0, 2.0, 3.0]],
            vel: vec![[0.0; 3]],
            omega: vec![],
            radius: vec![0.5],
            fixed: vec![false],
            orientation: vec![],
            half_length: vec![],
        };
        let s = frame_to_vtu(&f, Encoding::Ascii);
        assert!(s.contains("NumberOfPoints=\"1\" NumberOfCells=\"1\""));
        assert!(!s.contains("orientation"));
        assert!(!s.contains("angular_velocity"));
        assert!(s.contains("1e0 2e0 3e0"), "{s}");
    }
}
