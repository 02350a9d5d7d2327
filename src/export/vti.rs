//! A coarse-grained field set as a VTK `ImageData` (`.vti`): the set's grid as a uniform image,
//! each field a point array named `field [units]` (`phi [1]`, `velocity [m/s]`,
//! `contact_stress [Pa]`), 1, 3 or 9 components (tensors row-major, as VTK's 9-component
//! tensors). The store's point order (axis 0 fastest) is VTK's, so values are copied as they are.
//!
//! Grids: `xyz` maps axis k to x, y, z. `z` is a line of points along z at the stored x, y.
//! `rz` is drawn in the vertical half-plane y = 0 with x = r ≥ 0 and z = z, i.e. a slice through
//! the silo's axis; its image is `nr × 1 × nz`, which keeps the stored order unchanged. On that
//! half-plane the cylindrical basis (e_r, e_θ, e_z) is (e_x, e_y, e_z), so vector and tensor
//! components show correctly whether the observer stored them cylindrical or Cartesian. The
//! set's kernel, window and sample count go in `FieldData`.

use std::fmt::Write;

use super::data_array::{vtk_file_open, write_data_array, Encoding, Values};
use crate::store::fields::{FieldArray, FieldSet};

/// The image's origin, spacing and points per axis (x, y, z) for `set`.
pub fn image_geometry(set: &FieldSet) -> ([f64; 3], [f64; 3], [usize; 3]) {
    // An axis with one point has no spacing of its own; VTK wants a positive one anyway.
    let sp = |a: usize| {
        let s = set.spacing_m[a];
        if s > 0.0 {
            s
        } else {
            1.0
        }
    };
    match set.grid_kind.as_str() {
        "rz" => (
            [set.origin_m[0], 0.0, set.origin_m[1]],
            [sp(0), sp(2), sp(1)],
            [set.shape[0], 1, set.shape[1]],
        ),
        _ => (set.origin_m, [sp(0), sp(1), sp(2)], set.shape),
    }
}

/// The `.vti` text of `set` with its `arrays`.
///
/// # Errors
/// An array whose length is not points × components (the store refuses those on write, so this
/// means a damaged database).
pub fn field_set_to_vti(
    set: &FieldSet,
    arrays: &[FieldArray],
    encoding: Encoding,
) -> Result<String, String> {
    let (origin, spacing, n) = image_geometry(set);
    let points = n.iter().product::<usize>();
    for a in arrays {
        if a.data.len() != points * a.components {
            return Err(format!(
                "field set {} of job {}: {} has {} values, expected {points} points × {} components",
                set.name,
                set.job_id,
                a.field,
                a.data.len(),
                a.components
            ));
        }
    }
    let extent = format!("0 {} 0 {} 0 {}", n[0] - 1, n[1] - 1, n[2] - 1);
    let mut o = vtk_file_open("ImageData");
    writeln!(
        o,
        "  <ImageData WholeExtent=\"{extent}\" Origin=\"{:e} {:e} {:e}\" Spacing=\"{:e} {:e} {:e}\">",
        origin[0], origin[1], origin[2], spacing[0], spacing[1], spacing[2]
    )
    .expect("string");
    o.push_str("    <FieldData>\n");
    let meta = [
        ("TimeValue", 0.5 * (set.t_start_s + set.t_end_s)),
        ("t_start [s]", set.t_start_s),
        ("t_end [s]", set.t_end_s),
        ("kernel_width [m]", set.kernel_width_m),
        ("cutoff [widths]", set.cutoff_widths),
    ];
    for (name, v) in meta {
        write_data_array(&mut o, "      ", name, 1, Values::F64(&[v]), encoding);
    }
    write_data_array(
        &mut o,
        "      ",
        "samples",
        1,
        Values::I64(&[set.samples]),
        encoding,
    );
    o.push_str("    </FieldData>\n");
    writeln!(o, "    <Piece Extent=\"{extent}\">").expect("string");
    o.push_str("      <PointData>\n");
    for a in arrays {
        let name = array_name(a);
        write_data_array(
            &mut o,
            "        ",
            &name,
            a.components,
            Values::F64(&a.data),
            encoding,
        );
    }
    o.push_str("      </PointData>\n");
    o.push_str("    </Piece>\n");
    writeln!(o, "  </ImageData>\n</VTKFile>").expect("string");
    Ok(o)
}

/// The array's name in VTK files: `field [units]`.
pub fn array_name(a: &FieldArray) -> String {
    format!("{} [{}]", a.field, a.units)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(kind: &str, shape: [usize; 3]) -> FieldSet {
        FieldSet {
            id: 1,
            job_id: 1,
            name: "mean".into(),
            grid_kind: kind.into(),
            origin_m: [0.001, -0.05, 0.0],
            spacing_m: [0.002, 0.004, 0.0],
            shape,
            kernel_width_m: 0.003,
            cutoff_widths: 3.0,
            t_start_s: 1.0,
            t_end_s: 3.0,
            samples: 20,
        }
    }

    #[test]
    fn rz_sets_lie_in_the_xz_half_plane() {
        let (o, s, n) = image_geometry(&set("rz", [4, 6, 1]));
        assert_eq!(o, [0.001, 0.0, -0.05]);
        assert_eq!(s, [0.002, 1.0, 0.004]);
        assert_eq!(n, [4, 1, 6]);
        let (o, _, n) = image_geometry(&set("xyz", [2, 3, 4]));
        assert_eq!((o, n), ([0.001, -0.05, 0.0], [2, 3, 4]));
    }

    #[test]
    fn a_short_array_is_refused_with_its_name() {
        let a = FieldArray {
            field: "phi".into(),
            units: "1".into(),
            components: 1,
            data: vec![0.5; 3],
        };
        let e = field_set_to_vti(&set("rz", [4, 6, 1]), &[a], Encoding::Ascii).unwrap_err();
        assert!(e.contains("phi has 3 values, expected 24 points"), "{e}");
    }
}
