//! A coarse-grained field set as observers hand it over and the store keeps it: one grid and
//! time window (`FieldSet`) and the fields on it (`FieldArray`, point index `(k*ny + j)*nx + i`,
//! axis 0 fastest as in VTK, then components).

/// One grid and time window of a job's coarse-grained fields.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldSet {
    /// Row id (ignored by `save_field_set`, which returns the new one).
    pub id: i64,
    pub job_id: i64,
    /// Unique per job: `map_t3.000`, `mean`, `orifice_profile`, …
    pub name: String,
    /// `z`, `rz` or `xyz`.
    pub grid_kind: String,
    /// Position of point (0, 0, 0) (m); for `rz` axis 0 is r and axis 1 is z.
    pub origin_m: [f64; 3],
    pub spacing_m: [f64; 3],
    /// Points per axis; an unused axis has 1.
    pub shape: [usize; 3],
    /// Gaussian width w (m).
    pub kernel_width_m: f64,
    /// Cutoff in units of w.
    pub cutoff_widths: f64,
    /// Time window averaged (s since the orifice opened); equal for a single snapshot.
    pub t_start_s: f64,
    pub t_end_s: f64,
    /// Snapshots averaged.
    pub samples: i64,
}

impl FieldSet {
    /// Number of grid points.
    pub fn points(&self) -> usize {
        self.shape.iter().product()
    }

    /// Coordinate of point `i` along `axis` (m).
    pub fn coordinate(&self, axis: usize, i: usize) -> f64 {
        self.origin_m[axis] + i as f64 * self.spacing_m[axis]
    }
}

/// One field on a set's grid.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldArray {
    /// `phi`, `density`, `momentum`, `velocity`, `kinetic_stress`, `kinetic_pressure`, …
    pub field: String,
    /// SI units: `kg/m^3`, `m/s`, `Pa`, `1`.
    pub units: String,
    /// 1 scalar, 3 vector, 9 tensor (row-major).
    pub components: usize,
    /// `points × components` values, point-major.
    pub data: Vec<f64>,
}

impl FieldArray {
    /// Component `c` at point `p`.
    pub fn at(&self, p: usize, c: usize) -> f64 {
        self.data[p * self.components + c]
    }
}
